"""Regenerate ``docs/results.md`` and its plots: the paper's evaluation of the shipped policies.

    python docs/make_results.py                      # 2D, 3D and 7D (resumes; see below)
    python docs/make_results.py --worlds 2d --workers 2
    python docs/make_results.py --worlds 2d --task-draws 5  # and the spread over 4 more draws

For each world it runs ``trainers/evaluate.py --config configs/{2d,3d,7d}.yaml`` with the
shipped checkpoint (resumable: a rerun skips the finished tasks in ``results/{env id}``), copies
the plots to ``docs/results/{2d,3d,7d}/`` and writes ``docs/results.md``: the Table 1 layout
with medians and means and their bootstrap intervals, our TEMP/IRRT* time ratios next to the
paper's, and the acceptance checks (TEMP faster and with fewer nodes than every baseline in
every row; TEMP's success rate at least 99%), each marked from the measured figures: met when
the 95% interval of the median per-task ratio lies below 1, missed when it lies above,
undecided when it holds 1 (a rerun on a loaded machine could go either way).

A world left out of ``--worlds``, or whose results are not on this machine, keeps its section,
check lines and ratio lines from the ``docs/results.md`` already there (the page says which).

``--task-draws N`` also evaluates N - 1 more draws of test tasks (``evaluation.seed`` 1 ..
N - 1: other tasks, other planner seeds; results in ``results/{env id}-draw{k}``, resumable)
and adds, per row, the paired time ratios of each draw and of all draws pooled. One draw of
100 tasks is the paper's protocol; its paired ratio is a sum over heavy-tailed times, which a
few tasks can move by a factor of two, so the pooled figure says more about what users see.
"""

from __future__ import annotations

import json
import math
import platform
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from temp_gym.config import count, script_parser  # noqa: E402
from temp_gym.config.checks import check_output_dir  # noqa: E402
from temp_gym.evaluation import command as evaluate  # noqa: E402
from temp_gym.evaluation.protocol import TAU  # noqa: E402
from temp_gym.evaluation.statistics import format_interval  # noqa: E402
from temp_gym.jobs import run_script  # noqa: E402
from temp_gym.limits import MAX_WORKERS  # noqa: E402

WORLDS = {"2d": "TEMP-2D-v0", "3d": "TEMP-3D-v0", "7d": "TEMP-7D-v0"}
PAPER_TABLE = {
    "2D easy": ((0.154, 117), (0.531, 274)),
    "2D challenging": ((0.283, 211), (1.197, 604)),
    "3D easy": ((0.145, 89), (1.462, 426)),
    "3D challenging": ((0.222, 134), (2.085, 705)),
    "7D": ((0.754, 208), (6.940, 782)),
}
"""The paper's Table 1, per row: TEMP's and IRRT*'s mean ``(time in s, nodes)``."""


def paper_ratios(group: str) -> tuple[float, float, float] | None:
    """The paper's TEMP/IRRT* ``(time, nodes, time-per-node)`` ratios of a row (`PAPER_TABLE`)."""
    if group not in PAPER_TABLE:
        return None
    (temp_time, temp_nodes), (irrt_time, irrt_nodes) = PAPER_TABLE[group]
    time, nodes = temp_time / irrt_time, temp_nodes / irrt_nodes
    return time, nodes, time / nodes


PLOTS = ("success_vs_time.png", "cost_vs_nodes.png", "sampling_failures.png", "attention.png")
MIN_SUCCESS = 0.99
MAX_PAIRED_TIME = 0.7
"""The project's bound on TEMP's paired time ratio to each baseline, in every row."""


def _fmt(value: float | None, digits: int = 3) -> str:
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:.{digits}f}"


def _relative(path: str | None) -> str | None:
    """A path inside the repository, relative to it (shipped checkpoints are)."""
    if path is None:
        return None
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return path


def verdict(per_task: dict | None) -> str:
    """Whether TEMP is faster and needs fewer nodes than a baseline: met, missed or undecided.

    Read on the median per-task ratios (TEMP over the baseline, tasks both solved) and their
    95% bootstrap intervals: met when both intervals lie below 1, missed when either lies
    above 1, undecided otherwise. A verdict that an interval backs survives a rerun.
    """
    if not per_task:
        return "**missed**"
    time, nodes = per_task["time"], per_task["nodes"]
    if time["median_high"] < 1.0 and nodes["median_high"] < 1.0:
        return "met"
    if time["median_low"] > 1.0 or nodes["median_low"] > 1.0:
        return "**missed**"
    return "undecided"


def _median(statistics: dict | None) -> str:
    if not statistics:
        return "n/a"
    return format_interval(statistics, "median")


def attention_shares(records: list[dict]) -> dict[str, float]:
    """Per row, the share of TEMP's solved tasks that its attention phase solved alone."""
    solved: dict[str, list[bool]] = {}
    for record in records:
        temp = record["planners"]["temp"]
        if temp.get("success") and "attention_solved" in temp:
            solved.setdefault(record["group"], []).append(bool(temp["attention_solved"]))
    return {group: sum(flags) / len(flags) for group, flags in solved.items()}


def checks(summary: dict, attention: dict[str, float] | None = None) -> list[str]:
    """One markdown line per row: the acceptance checks, measured.

    "Faster and fewer nodes" is read on the tasks TEMP and the baseline both solved: the
    median per-task ratios with their intervals (`verdict`). The paired time ratio (sums of
    TEMP's times over the baseline's on those tasks) is held to `MAX_PAIRED_TIME`.
    """
    lines = []
    for group, data in summary["groups"].items():
        temp = data["rows"]["temp"]
        verdicts = []
        for name, ratio in data["temp_over"].items():
            per_task = ratio.get("per_task")
            pairs = per_task["time"]["n"] if per_task else 0
            paired = (ratio.get("paired") or {}).get("time")
            within = paired is not None and paired <= MAX_PAIRED_TIME
            verdicts.append(
                f"{name}: {verdict(per_task)}; paired time {_fmt(paired)} "
                f"({'met' if within else '**missed**'}) (median per-task time ratio "
                f"{_median(per_task and per_task['time'])}, nodes "
                f"{_median(per_task and per_task['nodes'])}, {pairs} tasks)"
            )
        success = temp["success_rate"] >= MIN_SUCCESS
        share = (attention or {}).get(group)
        lines.append(
            f"| {group} | {'; '.join(verdicts)} | "
            f"{temp['success_rate']:.3f} ({'met' if success else '**missed**'})"
            + (f"; attention phase alone {share:.3f}" if share is not None else "")
            + " |"
        )
    return lines


def world_section(key: str, out: Path, docs: Path) -> tuple[str, list[str], list[str]]:
    """Markdown of one world, its ratio lines and check lines (copies the plots)."""
    results = json.loads((out / "results.json").read_text())
    summary = results["summary"]
    target = docs / "results" / key
    target.mkdir(parents=True, exist_ok=True)
    for name in PLOTS:
        if (out / name).is_file():
            shutil.copyfile(out / name, target / name)
    ratios = []
    for group, data in summary["groups"].items():
        informed = data["temp_over"].get("informed_rrt_star", {})
        paired_figures = informed.get("paired") or {}
        paired, paired_nodes = paired_figures.get("time"), paired_figures.get("nodes")
        per_task = (informed.get("per_task") or {}).get("time")
        per_node = paired / paired_nodes if paired is not None and paired_nodes else None
        paper = paper_ratios(group)
        ours = f"{_fmt(paired_nodes)} | {_fmt(per_node, 2)}"
        ratios.append(
            f"| {group} | {_fmt(informed.get('time'))} | {_fmt(paired)} | {_median(per_task)} | "
            + (
                f"{paper[0]:.2f} | {ours} | {paper[1]:.3f} | {paper[2]:.2f} |"
                if paper
                else f"n/a | {ours} | n/a | n/a |"
            )
        )
    settings = results.get("settings", {})
    text = [
        f"## {WORLDS[key]}",
        "",
        f"Checkpoint `{_relative(results.get('checkpoint'))}` (weights digest "
        f"`{str(results.get('checkpoint_digest'))[:16]}`); settings: `{json.dumps(settings)}`.",
        "",
        (out / "results.md").read_text().strip(),
        "",
        *(f"![{name[:-4]}](results/{key}/{name})" for name in PLOTS if (target / name).is_file()),
        "",
    ]
    return "\n".join(text), ratios, checks(summary, attention_shares(results.get("records", [])))


def paired_sums(records: list[dict], baselines: list[str]) -> dict[str, dict[str, list[float]]]:
    """Per row and baseline: ``[TEMP's summed time, the baseline's, tasks]``, both solved."""
    sums: dict[str, dict[str, list[float]]] = {}
    for record in records:
        planners = record["planners"]
        if not planners["temp"].get("success"):
            continue
        row = sums.setdefault(record["group"], {b: [0.0, 0.0, 0] for b in baselines})
        for name in baselines:
            theirs = planners.get(name)
            if theirs and theirs.get("success"):
                row[name][0] += planners["temp"]["time"]
                row[name][1] += theirs["time"]
                row[name][2] += 1
    return sums


def spread_section(draws: list[dict]) -> list[str]:
    """Markdown: per row and baseline, the paired time ratio of each draw and of all pooled.

    ``draws`` are results.json contents, the paper's draw first.
    """
    baselines = list(draws[0].get("settings", {}).get("baselines", []))
    if not baselines:  # results written without their settings: the records' planners
        seen = (name for d in draws for r in d.get("records", []) for name in r["planners"])
        baselines = [name for name in dict.fromkeys(seen) if name != "temp"]
    per_draw = [paired_sums(d.get("records", []), baselines) for d in draws]
    lines = [
        f"Paired time ratio (TEMP over the baseline, sums over the tasks both solved) on "
        f"{len(draws)} draws of test tasks (`evaluation.seed` 0 .. {len(draws) - 1}; draw 0 is "
        "the one above), and pooled over all of them:",
        "",
        "| row | baseline | per draw | pooled | tasks pooled |",
        "|---|---|---|---:|---:|",
    ]
    for row in per_draw[0]:
        for name in baselines:
            pairs = [sums[row][name] for sums in per_draw if row in sums]
            each = ", ".join(_fmt(a / b if b > 0 else math.nan, 2) for a, b, _ in pairs)
            temp, theirs, tasks = (sum(column) for column in zip(*pairs))
            lines.append(
                f"| {row} | {name} | {each} | {_fmt(temp / theirs if theirs > 0 else math.nan)} "
                f"| {tasks} |"
            )
    lines += ["", "TEMP over all draws: " + "; ".join(
        f"{row}: solved {solved} of {total}, its attention phase alone {alone} (both ways, from "
        f"the start, or from the goal after a stall, or in a later round: {both})"
        for row, (solved, alone, both, total) in _temp_counts(draws).items()
    ) + "."]  # fmt: skip
    return lines


def _temp_counts(draws: list[dict]) -> dict[str, tuple[int, int, int, int]]:
    """Per row, over all draws: solved, attention phase alone, both ways, tasks.

    TEMP's solved tasks, those its attention phase solved from the start alone, those it
    solved both ways (from the start, or from the goal after a stall, or in a later round of
    the two: `BOTH_WAYS_KEYS`), and all tasks.
    """
    counts: dict[str, list[int]] = {}
    for d in draws:
        for record in d.get("records", []):
            temp = record["planners"]["temp"]
            row = counts.setdefault(record["group"], [0, 0, 0, 0])
            row[0] += bool(temp.get("success"))
            row[1] += bool(temp.get("success") and temp.get("attention_solved"))
            row[2] += bool(temp.get("success") and any(temp.get(key) for key in BOTH_WAYS_KEYS))
            row[3] += 1
    return {row: tuple(values) for row, values in counts.items()}


BOTH_WAYS_KEYS = ("attention_solved", "from_goal_solved", "rounds_solved")
"""A TEMP record's keys of the attention phases before any classical node (any one solved it)."""


KEPT_NOTE = (
    "*Kept from an earlier regeneration of this page: this world's results were not on the "
    "machine that regenerated it, so its figures are those of the checkpoint and code named here "
    "and may predate the other worlds'.*"
)


def carried_over(page: str, key: str) -> tuple[str, list[str], list[str]] | None:
    """A world's section, ratio lines and check lines from an existing results page, or None.

    Lines of the two summary tables belong to a world when their row starts with its label
    (``| 2D easy |``, ``| 7D |``); its section runs from ``## {env id}`` to the next world's.
    """
    heading = f"## {WORLDS[key]}"
    if heading not in page:
        return None
    section = heading + page.split(heading, 1)[1]
    later = [section.find(f"\n## {env}") for env in WORLDS.values() if env != WORLDS[key]]
    later = [index for index in later if index > 0]
    section = section[: min(later)] if later else section
    label = f"| {key.upper()}"
    head, _, _ = page.partition("\n## TEMP-")
    tables = head.split("## TEMP / Informed RRT* time ratio", 1)
    checks_part, ratios_part = tables if len(tables) == 2 else (head, "")

    def owned(text: str) -> list[str]:
        return [line for line in text.splitlines() if line.startswith((label + " ", label + "|"))]

    if KEPT_NOTE not in section:
        section = section.replace(heading, f"{heading}\n\n{KEPT_NOTE}", 1)
    return section.rstrip() + "\n", owned(ratios_part), owned(checks_part)


def main(argv: list[str] | None = None) -> Path:
    """Evaluate (resuming) and write ``docs/results.md``; return its path."""
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Outputs: results/{env id}[-draw{n}]/ (trainers/evaluate.py's, resumable) and "
        "{docs-dir}/results.md.",
    )
    parser.add_argument(
        "--worlds", nargs="+", default=list(WORLDS), choices=list(WORLDS), help="worlds to run"
    )
    parser.add_argument(
        "--workers", type=count(1, MAX_WORKERS), default=None,
        help="processes per evaluation (None: each config's evaluation.workers)",
    )  # fmt: skip
    parser.add_argument("--skip-evaluation", action="store_true", help="only rewrite the page")
    parser.add_argument("--docs-dir", default=str(ROOT / "docs"), help="where results.md goes")
    parser.add_argument(
        "--task-draws", type=count(1, 1000), default=1,
        help="draws of test tasks per world (1: the paper's protocol alone; see the docstring)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    docs = check_output_dir(args.docs_dir, "--docs-dir")
    previous = (docs / "results.md").read_text() if (docs / "results.md").is_file() else ""
    sections, ratios, check_lines = [], [], []
    for key in WORLDS:
        out = Path("results") / WORLDS[key]
        outs = [out] + [
            Path("results") / f"{WORLDS[key]}-draw{draw}" for draw in range(1, args.task_draws)
        ]
        if key in args.worlds and not args.skip_evaluation:
            for draw, where in enumerate(outs):
                flags = ["--config", f"configs/{key}.yaml", f"evaluation.out={where}"]
                flags += [f"evaluation.seed={draw}"] if draw else []
                if args.workers:
                    flags += ["--workers", str(args.workers)]
                evaluate.main(flags)
        if key in args.worlds and (out / "results.json").is_file():
            text, world_ratios, world_checks = world_section(key, out, docs)
            draws = [json.loads((where / "results.json").read_text())
                     for where in outs if (where / "results.json").is_file()]  # fmt: skip
            if len(draws) > 1:
                text += "\n### Spread over draws of test tasks\n\n"
                text += "\n".join(spread_section(draws)) + "\n"
        else:
            kept = carried_over(previous, key)
            if kept is None:
                print(f"{out}/results.json missing and no earlier section: {key} left out")
                continue
            print(f"{key}: no new results here; its section is kept from the earlier page")
            text, world_ratios, world_checks = kept
        sections.append(text)
        ratios += world_ratios
        check_lines += world_checks
    page = [
        "# Results: TEMP against RRT* and Informed RRT* (the paper's protocol)",
        "",
        "Regenerate with `python docs/make_results.py` (resumable): per world it runs "
        "`python trainers/evaluate.py --config configs/{2d,3d,7d}.yaml` with the shipped "
        "policy. [Evaluation](evaluation.md) explains the protocol; in short:",
        "",
        "- **TEMP** plans each test task on a workspace no training run has seen. Its first "
        "solution gives the time t, the nodes N and the cost J. That is TEMP as a user gets it: "
        "the attention phase's solution, as in the paper, or after a stall the one Informed "
        "RRT* and the resumed attention phase find on the same tree.",
        "- **Every baseline** (our RRT* and Informed RRT*, OMPL's two) runs on the same task "
        f"until its cost is at most (1 + {TAU}) J. A baseline's success is reaching that "
        "cost within its budget; TEMP's success is solving the task.",
        "- **Figures** are medians and means over the tasks each planner solved, with 95% "
        f"bootstrap intervals. Times are wall-clock on {platform.machine()} CPU cores of a "
        "shared 2-core machine, one process per task.",
        "- **Timing is fair to every planner.** Each timed run follows an untimed short run of "
        "the same planner on a problem in a training workspace (`warm_runs`), so the order in "
        "which the planners run does not bias their times. It also starts on a workspace the "
        "planners have forgotten (`fresh_workspaces`: the tree's free volume, TEMP's occupancy "
        "grid and encoding), as a user's first plan on a new workspace does.",
        "- **One draw of 100 tasks per row is the paper's protocol.** A few heavy-tailed tasks "
        "can move its paired ratio by a factor of two, so a world's section may add the paired "
        "ratios over more draws of test tasks (`--task-draws`).",
        "",
        "Each world's section lists the settings it was measured with. Where a section's "
        "settings lack one of these keys, the planner of that run lacked the feature:",
        "",
        "| key | without it in a section's settings |",
        "|---|---|",
        "| `goal_tree` | the classical phase grew no second tree from the goal |",
        "| `attention_from_goal` | after a stall the policy did not grow the goal tree first |",
        "| `attention_rounds` | no further rounds of the attention phase from both trees |",
        "| `attention_resume_growth` | equal classical turns between resumed attention phases |",
        "| `path_window` | the MPT read the whole path so far (with it: that many newest nodes) |",
        "| `warm_runs` | no warm runs: TEMP ran first on each task, each baseline right after "
        "another planner on the same workspace |",
        "| `fresh_workspaces` | TEMP, first on each task, paid the tree's set-up and the "
        "baselines found it cached |",
        "",
        "## Acceptance checks",
        "",
        "Faster and fewer nodes: met when the 95% bootstrap interval of the median per-task "
        "ratio (TEMP over the baseline, tasks both solved) lies below 1 for time and nodes, "
        "missed when it lies above 1, undecided when it holds 1.",
        "",
        "Paired time: the sum of TEMP's times over the baseline's on the tasks both solved, "
        f"held to at most {MAX_PAIRED_TIME} (the project's bound). The success column also "
        "gives the share of tasks TEMP's attention phase solved alone, from the start.",
        "",
        "| row | TEMP faster and with fewer nodes than each baseline | TEMP success (>= 0.99) |",
        "|---|---|---|",
        *check_lines,
        "",
        "## TEMP / Informed RRT* time ratio, ours next to the paper's",
        "",
        "A time ratio is a nodes ratio times a time-per-node ratio. The last four columns split "
        "the paired one (ours: paired sums, the time ratio over the nodes ratio; the paper's: "
        "its Table 1's means), so a row says whether TEMP is behind the paper in the nodes its "
        "policy saves or in what each of its nodes costs against a baseline node.",
        "",
        "| row | ours (row means) | ours (paired sums) | ours (median per task [95%]) | paper "
        "| ours: nodes (paired) | ours: time per node | paper: nodes | paper: time per node |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *ratios,
        "",
        *sections,
    ]
    path = docs / "results.md"
    path.write_text("\n".join(page) + "\n")
    print(f"wrote {path}")
    return path


if __name__ == "__main__":
    sys.exit(run_script("make_results.py", main))
