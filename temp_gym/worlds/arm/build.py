"""``temp-robot build DESCRIPTION.yaml``: an arm's derived data, written beside its description.

The derived data is what is slow to compute and the same every time, so it is computed once
and stored as ``<description stem>.derived.json``:

* **spheres**: per body, spheres covering each convex piece, bulging out of it by at most about
  the description's ``spheres.tolerance`` (`temp_gym.worlds.arm.spheres`); the fast checker
  arranges them in trees (`temp_gym.worlds.arm.sphere_tree`);
* **acm**: the allowed-collision matrix (`temp_gym.worlds.arm.acm`);
* **pair_tables**: joint-space clearance tables of close body pairs two joints apart
  (`temp_gym.worlds.arm.pair_tables`).

The file records the SHA-256 of everything it was computed from (the description's meaning,
URDF, SRDF and meshes: `temp_gym.worlds.arm.model.source_digest`). Loading an arm refuses a
file whose digest does not match, and the build skips the work when it does: running it again
changes nothing. Every step is deterministic (fixed seeds), so a rebuild writes the same bytes.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from temp_gym.config.command_line import CommandParser
from temp_gym.worlds.arm.description import DescriptionError, RobotDescription
from temp_gym.worlds.arm.model import DERIVED_FORMAT, ArmModel, load_arm, source_digest

_DECIMALS = 7
MANY_SPHERES = 10_000
"""A body with more covering spheres than this gets a hint to raise the tolerance: the built-in
arms have at most about 6,000 a body; a link a metre long at 1 mm gets tens of thousands,
which cost minutes to build and microseconds a state near a surface."""
BASE_TOLERANCE_FACTOR = 4
"""The base's spheres bulge this many times the robot's tolerance (4 mm at least): the base
never moves, so boxes are tested against its meshes once, by the exact checker, and its
spheres only meet other links, which are rarely that close to it."""


def _round(values: np.ndarray, up: bool = False) -> list:
    scale = 10**_DECIMALS
    rounded = (np.ceil if up else np.round)(np.asarray(values) * scale) / scale
    return rounded.tolist()


def fit_spheres(arm: ArmModel, log=print) -> list[dict]:
    """Per body, its pieces' covering spheres (JSON-ready: rounded so that they still cover)."""
    from temp_gym.worlds.arm.spheres import fit_piece

    bodies = []
    for body, geometry in enumerate(arm.geometry):
        tolerance = arm.description.sphere_tolerance
        if body == 0:  # the base meets boxes through the exact test, links only at a distance
            tolerance = max(BASE_TOLERANCE_FACTOR * tolerance, 0.004)
        centers, radii, bulge = [np.zeros((0, 3))], [np.zeros(0)], 0.0
        for piece in geometry.pieces:
            fitted = fit_piece(piece, tolerance)
            centers.append(fitted.centers)
            radii.append(fitted.radii)
            bulge = max(bulge, fitted.bulge)
        centers, radii = np.concatenate(centers), np.concatenate(radii)
        # Rounding moves a center by at most half a unit in each coordinate: grow the radius.
        slack = 0.5 * 10.0**-_DECIMALS * np.sqrt(3.0)
        bodies.append({
            "body": arm.body_names[body],
            "centers": _round(centers),
            "radii": _round(radii + slack, up=True),
            "bulge": round(bulge + slack, 6),
        })  # fmt: skip
        log(f"  {arm.body_names[body]}: {len(radii)} spheres, bulge {bulge * 1000:.2f} mm")
        if len(radii) > MANY_SPHERES:
            log(f"  ({arm.body_names[body]} is large for a {tolerance * 1000:g} mm tolerance: "
                "spheres: {tolerance: 0.006} in the description builds and checks faster, and "
                "the convex pieces still decide near surfaces)")  # fmt: skip
    return bodies


def compute_derived(arm: ArmModel, log=print) -> dict:
    """Everything the derived-data file holds (module docstring)."""
    from temp_gym.worlds.arm.acm import compute_acm
    from temp_gym.worlds.arm.pair_tables import compute_table, tabulated_pairs

    started = time.perf_counter()
    log(f"{arm.name}: fitting spheres (tolerance {arm.description.sphere_tolerance * 1000:g} mm)")
    spheres = fit_spheres(arm, log)
    log(f"{arm.name}: allowed-collision matrix")
    acm = compute_acm(arm)
    for links in acm["reported"]:
        log(f"  warning: {links[0]} - {links[1]} is not checked: in collision in nearly every "
            "sample")  # fmt: skip
    pairs = tabulated_pairs(acm)
    if pairs:
        log(f"{arm.name}: pair tables for {[arm.pair_name(a, b) for a, b in pairs]}")
    tables = [compute_table(arm, pair) for pair in pairs]
    log(f"{arm.name}: built in {time.perf_counter() - started:.0f} s")
    return {
        "format": DERIVED_FORMAT,
        "robot": arm.name,
        "source_digest": source_digest(arm.description, arm.chain),
        "body_names": list(arm.body_names),
        "spheres": {"tolerance": arm.description.sphere_tolerance, "bodies": spheres},
        "acm": acm,
        "pair_tables": tables,
    }


def refuse_built_in_names(description: RobotDescription) -> None:
    """Refuse, before any work, a description whose name or ids a built-in robot holds.

    Registering it would fail anyway (`temp_gym.worlds.robots.register_robot`), but only
    after a build of minutes. The built-in arms' own descriptions pass.
    """
    from temp_gym.worlds.robots import BUILT_IN, identity_clash

    own = description.path.resolve()
    clash = identity_clash(description, [spec for spec in BUILT_IN if spec.description != own])
    if clash is not None:
        field, spec = clash
        raise DescriptionError(
            f"{description.path.name}: {field}: {getattr(description, field)!r} is taken by the "
            f"built-in robot {spec.name!r}; give this robot another {field}"
        )


def build(path: str | Path, force: bool = False, log=print) -> Path:
    """Write the derived data of the description at ``path``; returns the file.

    Skips the work when the file exists and matches its sources (unless ``force``).
    """
    from temp_gym.files import write_json_atomic

    arm = load_arm(path, require_derived=False)
    refuse_built_in_names(arm.description)
    target = arm.description.derived_path
    if arm.derived is not None and not force:
        log(f"{arm.name}: {target.name} is up to date")
        return target
    data = compute_derived(arm, log)
    write_json_atomic(target, data, indent=None, sort_keys=False, separators=(",", ":"))
    log(f"wrote {target}")
    return target


def main(argv: list[str] | None = None) -> int:
    """``temp-robot``: build an arm's derived data from its robot description."""
    from temp_gym.worlds.arm.description import DescriptionError
    from temp_gym.worlds.arm.model import ArmDataError
    from temp_gym.worlds.arm.urdf import UrdfError

    parser = CommandParser(
        prog="temp-robot",
        description="Robot descriptions: build an arm's derived data (covering spheres, "
        "allowed-collision matrix, pair tables), written beside the description as "
        "<stem>.derived.json.",
    )
    commands = parser.add_subparsers(dest="command", required=True)
    build_parser = commands.add_parser(
        "build", help="write DESCRIPTION's derived data (a no-op when it is up to date)"
    )
    build_parser.add_argument("description", type=Path, help="robot description (YAML)")
    build_parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    check_parser = commands.add_parser(
        "check", help="exit 0 when DESCRIPTION loads and its derived data is up to date, else 2"
    )
    check_parser.add_argument("description", type=Path, help="robot description (YAML)")
    args = parser.parse_args(argv)
    try:
        if args.command == "build":
            build(args.description, force=args.force)
        else:
            # What `build` would refuse first, then the data.
            refuse_built_in_names(load_arm(args.description, require_derived=False).description)
            arm = load_arm(args.description)
            enabled = len(arm.enabled_pairs())
            print(f"{arm.name}: {arm.dim} joints, {arm.num_bodies} bodies, {enabled} body pairs "
                  "checked for self-collision; derived data up to date")  # fmt: skip
    except (DescriptionError, UrdfError, ArmDataError, OSError, json.JSONDecodeError) as error:
        print(f"temp-robot: {error}", file=sys.stderr)
        return 2
    return 0


__all__ = ["build", "compute_derived", "fit_spheres", "main", "refuse_built_in_names"]


if __name__ == "__main__":
    sys.exit(main())
