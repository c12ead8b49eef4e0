"""Fingerprints of what the library computes from seeds: problems, plans, env trees, a dataset,
evaluation records. A refactor must leave every one unchanged.

``python tests/golden/golden.py OUT.json`` writes them for the checkout on ``PYTHONPATH``;
``tests/golden/test_golden.py`` recomputes them and compares with the stored
``tests/golden/golden.json``, made with the code before the package was reorganized into its
layers (first at commit a490cc1, then at de0f33d, whose evaluation record version 2 changed
TEMP's figures) from an export of that commit:

    git archive de0f33d | tar -x -C /tmp/before
    PYTHONPATH=/tmp/before python tests/golden/golden.py tests/golden/golden.json

One intended change since: the point robots' rewiring radius now uses the exact free volume
(`PointBoxChecker.free_volume`) instead of a Monte Carlo estimate. The radius cap binds in every
plan of the sample, so only the tiny dataset's validation unit changed (its expert plans run
longer); ``dataset/val`` was rewritten with ``golden.py`` at that commit, all else kept.
Then the shipped 3D policy changed (the paper-scale chunked one): only the three 3D ``temp``
plans changed, and were rewritten the same way.
Then the EISE of a planning policy moved to `FastEISE` (numba, float64 sums) from PyTorch: the
SEI differs from torch's by float rounding (about 1e-6), so the ``temp`` plans of all three
worlds and the 7D evaluation record (TEMP's path) changed by rounding; their node counts did
not (checked on 250 test tasks in 2D and 3D). Those nine fingerprints were rewritten the same way.
Then the anytime loop (RRT*, Informed RRT*, TEMP's classical phase) moved into compiled code
(`temp_gym.planning._compiled_anytime`), which checks parent candidates one at a time instead
of in chunks: only ``collision_checks`` changed. With that field blanked in a copy of this
script, all 85 fingerprints were identical before and after; the plans were rewritten.
Then the shipped 2D policy changed (a smaller MPT trained on the mixed workspace families):
only the three 2D ``temp`` plans and the 2D evaluation record (TEMP's path) changed, and were
rewritten the same way.
Then the shipped 3D policy changed (a tiny MPT trained on the mixed workspace families): only
the three 3D ``temp`` plans changed, and were rewritten the same way.
Then the shipped 2D policy changed (the same tiny MPT with an EISE of hidden width 32, no output
noise): only the three 2D ``temp`` plans and the 2D evaluation record changed, and were
rewritten the same way.
Then a stalled attention phase resumes after classical planning (``attention_resume``): TEMP's
``attention`` record gained a ``resumes`` count, so the eight ``temp`` plans changed. No plan
of the sample stalls: with that key left out, all 85 fingerprints were identical before and
after, with resuming on and off. The eight were rewritten the same way.

Then the fingerprints turned out to depend on the machine: a CI run on another CPU failed on
the eight ``temp`` plans and the 7D evaluation record, and an AMD machine differed on those
and on a 7D Informed RRT* plan. OpenBLAS picks
its kernel for the CPU when it loads, and the MPT's products (numba's ``np.dot``) and Informed
RRT*'s rotation (an SVD) round differently with each kernel. With the kernel the stored file
was made with (``OPENBLAS_CORETYPE=SkylakeX``), all 85 fingerprints were identical on an AMD
machine. So the fingerprints are now computed in a child process with OpenBLAS's Haswell
kernel (AVX2 and FMA, which every x86-64 machine since 2013 has), and the ten that depend on
it were rewritten under that kernel, all else identical. The numba code itself gave the same
bits on Intel and AMD hosts (no kernel allows reassociation beyond LayerNorm's row sums).

Then TEMP's policy grows the goal tree after a stall (``attention_from_goal``), evaluation
records gained ``from_goal_solved``, and the shipped 2D policy carries a stall patience of 100
nodes: the 2D challenging ``temp`` plan and both evaluation records changed. With the planner
of before forced (the default patience rule, ``attention_from_goal=False``, the new record key
left out) under the pinned kernel, every plan and evaluation fingerprint was identical; the
three were rewritten with the new code.
Then TEMP's policy takes another round from both trees after stalls from the start and from the
goal (``attention_rounds``), TEMP's ``attention`` gained ``rounds`` and ``rounds_solved`` and
evaluation records ``rounds_solved``: the same three changed. With no rounds forced
(``ATTENTION_ROUNDS = 0``) and the new keys left out, every fingerprint was identical; the
three were rewritten with the new code. Then the shipped 2D policy's patience became 40 nodes
with one round (its checkpoint's planner settings): only the 2D challenging ``temp`` plan and
the 2D evaluation record changed, and were rewritten.
Then the shipped 2D policy's MPT reads the newest 16 nodes of the path so far (its checkpoint's
``path_window``): only the 2D challenging ``temp`` plan changed (with ``path_window`` set back
to none every fingerprint was identical), and was rewritten. The shipped 3D policy's patience
of 30 nodes changed none (no 3D plan of the sample stalls).
Then the shipped 2D policy's patience became 30 nodes with two rounds: only the 2D challenging
``temp`` plan and the 2D evaluation record changed, and were rewritten.

Then a CI machine with AVX-512 (an Intel Xeon of a later generation) differed on the eight
``temp`` plans and both evaluation records with the code of before: numba compiles for the
host CPU, and the MPT's kernels rounded differently when compiled for it (not pinned down
further; LayerNorm's row sums, the one loop allowed to reassociate, are the likely place).
With numba compiling for Haswell too
(``NUMBA_CPU_NAME=haswell`` beside OpenBLAS's kernel, `PINNED_ENV`), all 85 fingerprints were
identical there, as stored; none was rewritten. numba keeps its caches per target CPU, so the
rest of the suite compiles for Haswell too (``tests/conftest.py``): the children load the
kernels the suite compiled instead of compiling each of them a second time.

Then the shipped 2D policy changed (the same tiny MPT with one layer instead of two): only the
three 2D ``temp`` plans and the 2D evaluation record changed, and were rewritten the same way.

Then the shipped policies' checkpoints declare ``attention_local_fallback`` (2D 5, 3D and 7D
20: a colliding proposal's first replacements drawn near it): two of the three 2D ``temp``
plans, the three 3D ones and the 2D evaluation record changed (no 7D plan of the sample
has a colliding proposal). With the setting at 0 every fingerprint was identical; the six were
rewritten.

Then the shipped 7D policy changed (the paper-scale one trained with self-collision): only the
two 7D ``temp`` plans and the 7D evaluation record changed, and were rewritten the same way.
Then the arm code became generic (one arm read from any URDF): the iiwa's fast checker is now
spheres that bulge at most about 1 mm out of its links instead of 38 coarse ones, its edge
checks refine near surfaces, and arm tasks lost their 1 cm clearance rule and gained goals near
surfaces. So every 7D fingerprint changed (its problems, the plans on them, the env episode and
the evaluation record) and was rewritten; every 2D and 3D fingerprint and the dataset were
identical.
Then a fresh machine (2026-11-30, AMD EPYC, Debian's glibc 2.36) differed on the eight
``temp`` plans, the 3D challenging Informed RRT* plan and both evaluation records: the
fingerprints that depend on floating-point rounding outside our code. It differed alike with
the code of before and with numpy 2.3.5 or 2.4.6, scipy 1.16.3 or 1.17.1 and numba 0.67.0 or
0.68.1 (OpenBLAS's Haswell kernel confirmed loaded), so the cause is outside the Python packages
the project installs (not pinned down further). Every other fingerprint was identical there;
the eleven were rewritten on that machine. The fast arm checker's distance fields and
compiled sphere trees (the same verdicts, tested state by state) then changed none.
Then the fast arm checker let a body's convex pieces decide the touches within its spheres'
bulge (a link a fraction of a millimetre from a box became free, and motion intervals near boxes
are certified by the pieces where the spheres could not): five 7D fingerprints changed (the env
episode, the evaluation record, the test task's RRT* and Informed RRT* plans, a generated
problem's ``temp`` plan) and were rewritten; every other fingerprint was identical.
Then a fresh machine of the first kind (2026-12-01, AMD EPYC with AVX-512, the same Debian glibc
2.36 and packages) gave the eleven rounding-sensitive fingerprints their values of before the
rewrite on the EPYC above (the two 7D ones as the later 7D changes made them there): the two
roundings belong to two kinds of machine, not to a change of code. Each of the eleven now has
its other value in ``tests/golden/golden_variants.json``, and either passes; a code change
still changes both, so it fails either way. The 3D Informed RRT* plan's difference is numpy's
AVX-512 dispatch (with ``NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR"`` this machine
gives golden.json's value); the ``temp`` plans' is not pinned down (neither that, nor PyTorch's
``ATEN_CPU_CAPABILITY=avx2`` nor oneDNN's ``ONEDNN_MAX_CPU_ISA=AVX2`` changes them). A rewrite
of one of these must write its variant on the other kind of machine too, or drop it. The test
recomputes the whole sample, section by section, each in a child process with the kernel pinned
(seconds once numba's caches are warm); ``python tests/golden/golden.py --check`` does the same
and prints what differs. On a CPU without AVX2 and FMA the test is skipped.

The sample: in each world, evaluation test tasks and generated problems; every built-in
planner (``rrt_star``, ``informed_rrt_star``, ``temp`` with the shipped policy) on them; an
env episode of seeded random actions; the tiny config's dataset (``configs/tiny.yaml``, one
training workspace); and one evaluation record with curves. Wall times are left out; all else
(paths, costs, node counts, histories, observations, dataset columns) is hashed exactly.
Only the public API that both layouts share is used.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROBOTS = ("point2d", "point3d", "kuka_iiwa14")
ENV_IDS = {"point2d": "TEMP-2D-v0", "point3d": "TEMP-3D-v0", "kuka_iiwa14": "TEMP-7D-v0"}
PLANNERS = ("rrt_star", "informed_rrt_star", "temp")
NODES = {"point2d": 400, "point3d": 400, "kuka_iiwa14": 300}
TIME_KEYS = ("time", "wall")
SECTIONS = ("problems", "plans", "env", "dataset", "evaluation")
PINNED_ENV = {"OPENBLAS_CORETYPE": "Haswell", "NUMBA_CPU_NAME": "haswell"}
"""What the fingerprints are computed under: OpenBLAS's kernel and the CPU numba compiles for,
both of which otherwise follow the CPU."""


def digest(value) -> str:
    """SHA-256 (first 16 hex digits) of an array's dtype, shape and bytes, or of JSON."""
    hasher = hashlib.sha256()
    if isinstance(value, np.ndarray) or np.isscalar(value):
        array = np.ascontiguousarray(value)
        hasher.update(f"{array.dtype.str}{array.shape}".encode())
        hasher.update(array.tobytes())
    else:
        hasher.update(json.dumps(value, sort_keys=True, default=_jsonable).encode())
    return hasher.hexdigest()[:16]


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(type(value))


def _untimed(value):
    """``value`` without the entries whose key names a time (they differ run to run)."""
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if not any(t in str(k) for t in TIME_KEYS)}
    if isinstance(value, (list, tuple)):
        return [_untimed(v) for v in value]
    return value


def problems() -> dict[str, object]:
    from temp_gym.evaluation.runner import evaluation_problem
    from temp_gym.worlds.generators import generate_problem

    found = {}
    for robot in ROBOTS:
        difficulties = ("any",) if robot == "kuka_iiwa14" else ("easy", "challenging")
        for difficulty in difficulties:
            found[f"{robot}/test/{difficulty}/0"] = evaluation_problem(robot, difficulty, 0)
        found[f"{robot}/generated/3"] = generate_problem(robot, np.random.default_rng(3), "any")
    return found


def plans(found: dict[str, object], robots: tuple[str, ...] = ROBOTS) -> dict[str, str]:
    from temp_gym import plan

    out = {}
    for name, problem in found.items():
        if problem.robot not in robots:
            continue
        for planner in PLANNERS:
            result = plan(problem, planner=planner, seed=1, max_nodes=NODES[problem.robot])
            record = {
                "success": result.success,
                "cost": result.cost,
                "nodes": result.nodes,
                "samples": result.samples,
                "sampling_failures": result.sampling_failures,
                "collision_checks": result.collision_checks,
                "nodes_to_first_solution": result.nodes_to_first_solution,
                "path": None if result.path is None else digest(np.asarray(result.path)),
                "history": {
                    k: digest(np.asarray(v))
                    for k, v in sorted(result.history.items())
                    if not any(t in k for t in TIME_KEYS)
                },
                "attention": _untimed(result.attention),
            }
            out[f"{name}/{planner}"] = digest(record)
    return out


def env_trees() -> dict[str, str]:
    import gymnasium

    import temp_gym  # noqa: F401  (registers the envs)

    out = {}
    for robot in ROBOTS:
        env = gymnasium.make(ENV_IDS[robot], max_nodes=200)
        observation, _ = env.reset(seed=7)
        rng = np.random.default_rng(7)
        parts = [digest({k: digest(np.asarray(v)) for k, v in sorted(observation.items())})]
        for _ in range(60):
            action = rng.uniform(-1, 1, size=env.action_space.shape).astype(np.float32)
            observation, reward, terminated, truncated, _ = env.step(action)
            parts.append(digest({k: digest(np.asarray(v)) for k, v in sorted(observation.items())}))
            parts.append(repr((float(reward), terminated, truncated)))
            if terminated or truncated:
                break
        tree = env.unwrapped.tree
        n = tree.num_nodes
        parts += [digest(np.asarray(tree.positions[:n])), digest(np.asarray(tree.parents[:n]))]
        parts.append(digest(np.asarray(tree.costs[:n])))
        out[robot] = digest(parts)
        env.close()
    return out


def dataset() -> dict[str, str]:
    import temp_gym
    from temp_gym.config import load_config
    from temp_gym.data.generate import generate_dataset

    root = Path(temp_gym.__file__).resolve().parents[1]  # the checkout being fingerprinted
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        config = load_config(
            root / "configs" / "tiny.yaml",
            [f"data.dir={folder}/tiny", "data.workspaces={train: 1, val: 1}"],
        )
        path = generate_dataset(config, workers=1, progress=False)
        for column in sorted(path.rglob("*.npy")):
            if any(t in column.name for t in TIME_KEYS):
                continue
            out[str(column.relative_to(path))] = digest(np.load(column, allow_pickle=False))
    return out


def evaluation_records(found: dict[str, object]) -> dict[str, str]:
    from temp_gym import load_policy
    from temp_gym.evaluation.runner import EvaluationSettings, evaluate_task

    out = {}
    for name in ("point2d/test/challenging/0", "kuka_iiwa14/test/any/0"):
        problem = found[name]
        settings = EvaluationSettings(
            robot=problem.robot,
            groups={"row": ("any", 1)},
            max_nodes=NODES[problem.robot],
            curve_nodes=NODES[problem.robot],
        )
        policy = load_policy(problem.robot, seed=0)
        record = evaluate_task(problem, policy, settings, with_curves=True)
        out[name] = digest(_untimed(record))
    return out


def fingerprints(sections: tuple[str, ...] = SECTIONS) -> dict[str, dict[str, str]]:
    """The fingerprints of the sample, by section (all of them by default)."""
    found = problems() if {"problems", "plans", "evaluation"} & set(sections) else {}
    compute = {
        "problems": lambda: {name: digest(p.to_dict()) for name, p in found.items()},
        "plans": lambda: plans(found),
        "env": env_trees,
        "dataset": dataset,
        "evaluation": lambda: evaluation_records(found),
    }
    return {section: compute[section]() for section in sections}


def pinned_kernel_supported() -> bool:
    """Whether this CPU runs OpenBLAS's Haswell kernel: x86-64 with AVX2 and FMA (Linux)."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    line = next((line for line in flags.splitlines() if line.startswith("flags")), "")
    return {"avx2", "fma"} <= set(line.split())


def is_pinned() -> bool:
    """Whether this process runs under `PINNED_ENV`."""
    return all(os.environ.get(key) == value for key, value in PINNED_ENV.items())


def run_pinned(argv: list[str]) -> subprocess.CompletedProcess:
    """This script with ``argv`` in a child process under `PINNED_ENV` (output captured)."""
    env = {**os.environ, **PINNED_ENV}
    command = [sys.executable, str(Path(__file__).resolve()), *argv]
    return subprocess.run(command, env=env, capture_output=True, text=True, check=False)


def differences(
    found: dict[str, dict[str, str]],
    stored: dict[str, dict[str, str]],
    variants: dict[str, dict[str, list[str]]] | None = None,
) -> list[str]:
    """The entries of ``found`` that differ from ``stored`` (or that it lacks), one line each.

    An entry equal to one of its ``variants`` (another machine's rounding, `VARIANTS`) does
    not differ.
    """
    variants = variants or {}
    return [
        f"{section}/{key}: {value} != {stored.get(section, {}).get(key)}"
        for section, entries in found.items()
        for key, value in entries.items()
        if stored.get(section, {}).get(key) != value
        and value not in variants.get(section, {}).get(key, [])
    ]


STORED = Path(__file__).with_name("golden.json")
VARIANTS = Path(__file__).with_name("golden_variants.json")
"""The rounding-sensitive fingerprints' values on the other kind of machine (module docstring)."""


def main(argv: list[str] | None = None) -> int:
    """``--check``: compare with the stored fingerprints (exit 1 if they differ); ``OUT``: write.

    Runs itself again under `PINNED_ENV` unless it already does (numpy has loaded OpenBLAS by
    the time this runs, too late to pin its kernel here).
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    action = parser.add_mutually_exclusive_group(required=True)
    action.add_argument("--check", action="store_true", help="compare with golden.json")
    action.add_argument("out", nargs="?", type=Path, help="write the fingerprints to this file")
    parser.add_argument(
        "--section", choices=SECTIONS, action="append", help="only these sections (repeatable)"
    )
    args = parser.parse_args(argv)
    if not is_pinned():
        child = run_pinned(sys.argv[1:] if argv is None else argv)
        print(child.stdout, end="")
        print(child.stderr, end="", file=sys.stderr)
        return child.returncode
    sections = tuple(args.section or SECTIONS)
    if args.check:  # the sample against the stored fingerprints
        lines = differences(
            fingerprints(sections),
            json.loads(STORED.read_text()),
            json.loads(VARIANTS.read_text()),
        )
        print("\n".join(lines) or "identical")
        return 1 if lines else 0
    if args.section:
        parser.error("writing takes the whole sample: leave out --section")
    args.out.write_text(json.dumps(fingerprints(), indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
