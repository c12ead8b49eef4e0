"""Screenshots of a page in headless Chromium: how the viewer is tested and pictured.

`screenshot` drives the system's Chromium (Debian: ``apt-get install chromium``) with
playwright (``temp-gym[test]``; playwright's own browser downloads are not needed): headless,
sandbox-less (root in CI), quiet on the network, with WebGL in software (SwiftShader), so it
needs neither a display nor a GPU. It waits in real time until the page shows what the
caller expects (``ready``), so a slow machine waits longer instead of taking a blank picture.

Example:
    >>> with view_plan(problem, result=result, port=0) as viewer:
    ...     image = screenshot(viewer.url, "shot.png", ready=lambda rgb: rgb.min() < 100)
"""

from __future__ import annotations

import io
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
"""Executables tried, in order, by `find_chromium`."""
CHROMIUM_FLAGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
)
"""Besides headless: root-friendly, quiet on the network, WebGL in software."""
HIDE_NOTIFICATIONS = "[class*='Notification']{display:none !important}"
"""CSS that hides pop-up notices (a software renderer is announced in one)."""


def find_chromium() -> str | None:
    """The path of a Chromium (or Chrome) executable on ``PATH``, or None."""
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def _rgb(png: bytes) -> np.ndarray:
    from matplotlib.image import imread

    image = imread(io.BytesIO(png), format="png")
    return (np.asarray(image[..., :3]) * 255).round().astype(np.uint8)


def screenshot(
    url: str,
    out: str | Path | None = None,
    width: int = 960,
    height: int = 640,
    ready: Callable[[np.ndarray], bool] | None = None,
    timeout: float = 60.0,
    settle: float = 1.0,
    chromium: str | None = None,
) -> np.ndarray:
    """Load ``url`` in headless Chromium and take a picture once it is ``ready``.

    Args:
        url: The page.
        out: A PNG file to write the picture to (None: none).
        width: Window width in pixels.
        height: Window height in pixels.
        ready: Called on each picture ``(height, width, 3)``; the first it accepts is kept.
            None: the first picture after ``settle`` seconds.
        timeout: Seconds of waiting for a picture ``ready`` accepts; then the last one is
            returned (the caller's checks tell what is missing).
        settle: Seconds to wait after loading before the first picture.
        chromium: The executable (None: `find_chromium`).

    Returns:
        The picture, ``uint8`` of shape ``(height, width, 3)``.

    Raises:
        FileNotFoundError: no Chromium.
        ImportError: no playwright (``pip install 'temp-gym[test]'``).
    """
    chromium = chromium or find_chromium()
    if chromium is None:
        raise FileNotFoundError(f"no Chromium on PATH (tried {', '.join(CHROMIUM_NAMES)})")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError as error:
        raise ImportError("screenshots need playwright: pip install 'temp-gym[test]'") from error
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=chromium, headless=True, args=list(CHROMIUM_FLAGS)
        )
        try:
            page = browser.new_page(viewport={"width": int(width), "height": int(height)})
            page.goto(url, timeout=timeout * 1000)
            page.add_style_tag(content=HIDE_NOTIFICATIONS)
            page.wait_for_timeout(settle * 1000)
            deadline = time.monotonic() + timeout
            while True:
                png = page.screenshot()
                image = _rgb(png)
                if ready is None or ready(image) or time.monotonic() > deadline:
                    break
                page.wait_for_timeout(250)
        finally:
            browser.close()
    if out is not None:
        Path(out).write_bytes(png)
    return image
