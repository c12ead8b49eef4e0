"""A small run prints nothing that the user did not ask for (pybullet banners, torchrl INFO)."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent(
    """
    import gymnasium as gym
    import temp_gym
    from temp_gym.config import load_config
    from temp_gym.data import generate_dataset, load_split

    env = gym.make("TEMP-7D-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    env.close()
    config = load_config("configs/tiny.yaml", [
        "data.dir=data", "data.workers=1", "data.workspaces={train: 1, val: 1}",
        "data.tasks_per_workspace=2", "data.max_nodes=150",
    ])
    generate_dataset(config, workers=1, progress=False)
    buffer, workspaces = load_split("data", "train")
    print("done", len(buffer) > 0)
    """
)


def test_rendering_and_datasets_print_only_what_was_asked(tmp_path):
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout == "done True\n"
    for noise in ("pybullet build time", "argv[0]", "[INFO]", "LazyMemmapStorage"):
        assert noise not in done.stderr


def test_silenced_native_output_is_replayed_when_the_block_fails(tmp_path):
    code = textwrap.dedent(
        """
        import os
        from temp_gym.quiet import native_output_silenced
        with native_output_silenced():
            os.write(1, b"hidden\\n")
        try:
            with native_output_silenced():
                os.write(1, b"explains the failure\\n")
                raise RuntimeError("boom")
        except RuntimeError:
            print("caught")
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "caught\n"
    assert "explains the failure" in done.stderr and "hidden" not in done.stderr + done.stdout
