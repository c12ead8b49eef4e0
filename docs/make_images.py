"""Make the pictures of the docs: the renders, the arm's families, the viewer, a benchmark.

Pictures: ``docs/images/render_{2d,3d,7d}.png``, ``families_7d.png``, ``viewer_7d.png`` and
``benchmark_2d.png``.

Run from the repository root::

    python docs/make_images.py            # all six pictures
    python docs/make_images.py --only 2d  # one of them

The 2D and 3D pictures grow an RRT* tree of 1500 nodes with uniform samples on a seeded
challenging point problem and draw its solution; the 7D one plans a seeded challenging iiwa
task with ``rrt_star`` and draws the arm along the path, from the camera the renderer chooses
for the scene. The families picture shows one workspace of each of the arm's structured
families (`temp_gym.worlds.arm_structured`) with the arm at a challenging task's start and
goal. The viewer picture is the 7D plan in the browser viewer (`temp_gym.viewer`), three
quarters along the path, taken in headless Chromium (it needs ``temp-gym[test,view]`` and a
Chromium). The benchmark picture is ``temp-benchmark``'s plot of RRT* and Informed RRT* on
the 2D out-of-distribution scenes (`BENCHMARK_SCENES`, 5 runs of 1 s each). Everything else is
seeded, so reruns give the same pictures; the benchmark's curves are timed, so they move a
little from run to run.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from temp_gym.config import script_parser

# matplotlib and the renderers (pybullet) load in the picture makers: ``--help`` stays light.

IMAGES = Path(__file__).resolve().parent / "images"
SEED_2D = 1
SEED_3D = 3
SEED_7D = 0
NODES = 1500
BENCHMARK_SCENES = ("narrow_gap", "bug_trap", "forest", "zigzag_3")
"""The 2D out-of-distribution scenes of the benchmark picture (``examples/ood/2d``)."""
FAMILY_SEEDS = {"corridors": 102, "maze": 102, "traps": 2, "narrow": 3, "clutter": 4}
"""Per arm family, the workspace shown: picked by eye among the first few, so that the
renderer's camera (chosen to show the arm) sees the structure's openings."""


def make_point(robot: str, seed: int, out: Path) -> None:
    """A challenging point problem, its RRT* tree and the best path."""
    from matplotlib.image import imsave

    from temp_gym.planning.tree import Tree
    from temp_gym.worlds.generators import generate_problem
    from temp_gym.worlds.rendering import render_point_world

    problem = generate_problem(robot, np.random.default_rng(seed), "challenging")
    tree = Tree(problem)
    rng = np.random.default_rng(0)
    low, high = problem.bounds
    while tree.num_nodes < NODES:
        tree.extend(rng.uniform(low, high))
    image = render_point_world(
        problem,
        positions=tree.positions,
        parents=tree.parents,
        num_nodes=tree.num_nodes,
        path=tree.best_path(),
        width=560,
        height=560,
    )
    imsave(out, image)


def make_2d(out: Path) -> None:
    """The point2d picture."""
    make_point("point2d", SEED_2D, out)


def make_3d(out: Path) -> None:
    """The point3d picture."""
    make_point("point3d", SEED_3D, out)


def plan_7d():
    """The challenging iiwa task of the 7D pictures and its RRT* plan."""
    from temp_gym.planning.plan import plan
    from temp_gym.worlds.generators import generate_task, generate_workspace

    rng = np.random.default_rng(SEED_7D)
    workspace = generate_workspace("kuka_iiwa14", rng)
    problem = generate_task(workspace, rng, "challenging")
    result = plan(problem, planner="rrt_star", seed=0, max_nodes=NODES)
    print(f"  {result.summary()}")
    return problem, result


def make_7d(out: Path) -> None:
    """A challenging iiwa task planned with RRT*, the arm drawn along the path."""
    from matplotlib.image import imsave

    from temp_gym.worlds.rendering import ArmRenderer, plan_title

    problem, result = plan_7d()
    with ArmRenderer() as renderer:
        title = plan_title(problem, result.nodes, result.path)
        image = renderer.render(problem, path=result.path, width=560, height=560, title=title)
    imsave(out, image)


def make_families_7d(out: Path) -> None:
    """One workspace of each of the iiwa's structured families, the arm at start and goal."""
    from matplotlib.image import imsave

    from temp_gym.worlds.arm_structured import FAMILY_STRUCTURES
    from temp_gym.worlds.generators import generate_task, generate_workspace
    from temp_gym.worlds.rendering import ArmRenderer

    tiles = []
    with ArmRenderer() as renderer:
        for family in FAMILY_STRUCTURES:
            rng = np.random.default_rng([SEED_7D, FAMILY_SEEDS[family]])
            workspace = generate_workspace("kuka_iiwa14", rng, family)
            problem = generate_task(workspace, rng, "challenging")
            tiles.append(renderer.render(problem, width=300, height=300, title=family))
    imsave(out, np.concatenate(tiles, axis=1))


def make_viewer_7d(out: Path) -> None:
    """The 7D plan in the browser viewer, the arm three quarters along the path."""
    from temp_gym.viewer import view_plan
    from temp_gym.viewer.browser import screenshot

    problem, result = plan_7d()
    with view_plan(problem, result=result, port=0) as viewer:
        viewer.show_frame(3 * viewer.content.frames // 4)
        screenshot(viewer.url, out, width=1100, height=640, settle=4.0)


def make_benchmark_2d(out: Path) -> None:
    """``temp-benchmark``'s plot: RRT* and Informed RRT* on four 2D scenes, 5 runs of 1 s."""
    import shutil
    import tempfile

    from temp_gym.evaluation.benchmark_command import main as benchmark

    scenes = Path(__file__).resolve().parents[1] / "examples" / "ood" / "2d"
    with tempfile.TemporaryDirectory() as folder:
        problems = Path(folder) / "ood-2d"
        problems.mkdir()
        for scene in BENCHMARK_SCENES:
            shutil.copy(scenes / f"{scene}.json", problems)
        argv = ["--problems", str(problems), "--planners", "rrt_star", "informed_rrt_star",
                "--runs", "5", "--time-limit", "1", "--group", "one", "--no-progress",
                "--out", str(Path(folder) / "out")]  # fmt: skip
        if benchmark(argv) != 0:
            raise RuntimeError("temp-benchmark failed")
        shutil.copy(Path(folder) / "out" / "plots" / "ood-2d.png", out)


PICTURES = {
    "2d": ("render_2d", make_2d),
    "3d": ("render_3d", make_3d),
    "7d": ("render_7d", make_7d),
    "families_7d": ("families_7d", make_families_7d),
    "viewer_7d": ("viewer_7d", make_viewer_7d),
    "benchmark_2d": ("benchmark_2d", make_benchmark_2d),
}
"""Picture name (``--only``) -> (file stem under `IMAGES`, its maker)."""


def main(argv: list[str] | None = None) -> int:
    """Make the pictures; return the number that failed."""
    parser = script_parser(__doc__.splitlines()[0], epilog=f"Output: {IMAGES}/{{picture}}.png.")
    parser.add_argument("--only", choices=tuple(PICTURES), help="make only this picture")
    args = parser.parse_args(argv)
    IMAGES.mkdir(parents=True, exist_ok=True)
    failed = 0
    for name, (stem, make) in PICTURES.items():
        if args.only not in (None, name):
            continue
        out = IMAGES / f"{stem}.png"
        start = time.perf_counter()
        try:
            make(out)
        except Exception as error:  # report and go on with the other picture
            print(f"{stem}: failed: {type(error).__name__}: {error}")
            failed += 1
            continue
        print(f"wrote {out} in {time.perf_counter() - start:.1f} s")
    return failed


if __name__ == "__main__":
    sys.exit(main())
