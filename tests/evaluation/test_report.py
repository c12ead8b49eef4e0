"""The report on small fake records: labels that say what they count, medians with intervals."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from temp_gym.evaluation.report import summarize, write_report

ROOT = Path(__file__).resolve().parents[2]


def fake_records(stall: float | None = None, tasks: int = 30, seed: int = 0) -> list[dict]:
    """TEMP about twice as fast as RRT* on every task; RRT* reaches 1.05 J on 80% of them."""
    rng = np.random.default_rng(seed)
    records = []
    for index in range(tasks):
        base = float(rng.uniform(0.01, 0.02))
        temp_time = base if stall is None or index != 0 else stall
        reached = index % 5 != 4
        records.append(
            {
                "group": "2D easy",
                "index": index,
                "planners": {
                    "temp": {"success": True, "time": temp_time, "nodes": 40 + index,
                             "sampling_failures": 3},
                    "rrt_star": {"success": reached, "time": 2 * base if reached else None,
                                 "nodes": 200 + index if reached else None,
                                 "sampling_failures": 30},
                },
            }
        )  # fmt: skip
    return records


def test_results_carry_medians_with_intervals_and_truthful_labels(tmp_path):
    write_report(fake_records(), tmp_path, tensorboard=False)
    text = (tmp_path / "results.md").read_text()
    assert "temp solved" in text and "rrt_star reached 1.05·J_TEMP" in text
    assert "success |" not in text  # no bare "success" column
    assert "time median (s) [95%]" in text and "time, median per task [95%]" in text
    summary = json.loads((tmp_path / "results.json").read_text())["summary"]
    group = summary["groups"]["2D easy"]
    temp = group["distributions"]["temp"]["time"]
    assert temp["n"] == 30 and temp["median_low"] <= temp["median"] <= temp["median_high"]
    assert group["distributions"]["rrt_star"]["nodes"]["n"] == 24  # only the tasks it reached
    per_task = group["temp_over"]["rrt_star"]["per_task"]
    assert per_task["time"]["median"] == pytest.approx(0.5)  # TEMP takes half the time
    assert per_task["nodes"]["median_high"] < 1


def test_one_stall_moves_the_ratio_of_sums_but_not_the_median_ratio():
    quiet = summarize(fake_records())["groups"]["2D easy"]["temp_over"]["rrt_star"]
    loaded = summarize(fake_records(stall=1.0))["groups"]["2D easy"]["temp_over"]["rrt_star"]
    assert quiet["paired"]["time"] < 1 < loaded["paired"]["time"]  # the mean-based claim flips
    assert loaded["per_task"]["time"]["median"] == pytest.approx(0.5)
    assert loaded["per_task"]["time"]["median_high"] < 1  # the median-based one does not


def test_plots_are_labelled_and_empty_panels_do_not_warn(tmp_path, recwarn):
    write_report(fake_records(tasks=6), tmp_path, tensorboard=False)  # no cost curves
    assert not [w for w in recwarn.list if "legend" in str(w.message).lower()]
    for name in ("success_vs_time.png", "cost_vs_nodes.png", "sampling_failures.png"):
        assert (tmp_path / name).stat().st_size > 0


def load_make_results():
    spec = importlib.util.spec_from_file_location("make_results", ROOT / "docs/make_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_make_results_reads_verdicts_off_the_intervals(tmp_path, monkeypatch):
    make_results = load_make_results()
    monkeypatch.chdir(tmp_path)
    write_report(fake_records(stall=1.0), tmp_path / "results" / "TEMP-2D-v0", tensorboard=False)
    page = make_results.main(
        ["--worlds", "2d", "--skip-evaluation", "--docs-dir", str(tmp_path / "docs")]
    ).read_text()
    # One stall: the median verdict stands, the paired (sums) time bound of 0.7 is missed.
    assert "rrt_star: met; paired time " in page
    assert "(**missed**) (median per-task time ratio 0.500 [" in page
    assert "ours (median per task [95%])" in page
    assert "time median (s) [95%]" in page
    slower = {"time": {"median": 1.5, "median_low": 1.2, "median_high": 1.9},
              "nodes": {"median": 0.5, "median_low": 0.4, "median_high": 0.6}}  # fmt: skip
    assert make_results.verdict(slower) == "**missed**"
    slower["time"].update(median_low=0.8)
    assert make_results.verdict(slower) == "undecided"
    assert make_results.verdict(None) == "**missed**"


def test_make_results_splits_the_time_ratio_into_nodes_and_time_per_node(tmp_path, monkeypatch):
    make_results = load_make_results()
    monkeypatch.chdir(tmp_path)
    records = fake_records(stall=1.0)
    for record in records:  # Informed RRT*: RRT*'s runs, a little faster on fewer nodes
        rrt = record["planners"]["rrt_star"]
        record["planners"]["informed_rrt_star"] = {
            **rrt,
            "time": rrt["time"] and 0.8 * rrt["time"],
            "nodes": rrt["nodes"] and rrt["nodes"] - 50,
        }
    write_report(records, tmp_path / "results" / "TEMP-2D-v0", tensorboard=False)
    page = make_results.main(
        ["--worlds", "2d", "--skip-evaluation", "--docs-dir", str(tmp_path / "docs")]
    ).read_text()
    both = [
        r["planners"]
        for r in records
        if r["group"] == "2D easy"
        and r["planners"]["temp"]["success"]
        and r["planners"]["informed_rrt_star"]["success"]
    ]
    sums = {key: [sum(p[n][key] for p in both) for n in ("temp", "informed_rrt_star")]
            for key in ("time", "nodes")}  # fmt: skip
    time_ratio = sums["time"][0] / sums["time"][1]
    nodes_ratio = sums["nodes"][0] / sums["nodes"][1]
    paper_time, paper_nodes, paper_per_node = make_results.paper_ratios("2D easy")
    assert paper_nodes == pytest.approx(117 / 274)
    assert paper_time == pytest.approx(0.154 / 0.531)  # the paper's 0.29
    assert paper_nodes * paper_per_node == pytest.approx(paper_time)
    line = next(x for x in page.splitlines() if x.startswith("| 2D easy | ") and "paper" not in x
                and x.count("|") == 10)  # fmt: skip
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[2] == f"{time_ratio:.3f}" and cells[4] == "0.29"
    assert cells[5] == f"{nodes_ratio:.3f}"
    assert cells[6] == f"{time_ratio / nodes_ratio:.2f}"
    assert cells[7:] == [f"{paper_nodes:.3f}", f"{paper_per_node:.2f}"]
    assert make_results.paper_ratios("4D") is None


def test_make_results_pools_draws_and_keeps_worlds_it_did_not_rerun(tmp_path, monkeypatch):
    make_results = load_make_results()
    monkeypatch.chdir(tmp_path)
    draws = [fake_records(seed=0), fake_records(stall=1.0, seed=1)]
    write_report(draws[0], tmp_path / "results" / "TEMP-2D-v0", tensorboard=False)
    write_report(draws[1], tmp_path / "results" / "TEMP-2D-v0-draw1", tensorboard=False)
    docs = ["--skip-evaluation", "--docs-dir", str(tmp_path / "docs")]
    page = make_results.main(["--worlds", "2d", "--task-draws", "2", *docs]).read_text()
    assert "### Spread over draws of test tasks" in page
    sums = [
        [sum(r["planners"][n]["time"] for r in records if r["planners"]["rrt_star"]["success"])
         for n in ("temp", "rrt_star")]
        for records in draws
    ]  # fmt: skip
    each = ", ".join(f"{a / b:.2f}" for a, b in sums)
    pooled = sum(a for a, _ in sums) / sum(b for _, b in sums)
    assert f"| 2D easy | rrt_star | {each} | {pooled:.3f} | 48 |" in page
    checks = [line for line in page.splitlines() if line.startswith("| 2D easy | rrt_star:")]
    assert len(checks) == 1

    # Without results on the machine, the world's section and its lines stay, marked as kept.
    (tmp_path / "results" / "TEMP-2D-v0" / "results.json").unlink()
    kept = make_results.main(["--worlds", "2d", *docs]).read_text()
    assert make_results.KEPT_NOTE in kept
    assert checks[0] in kept and "### Spread over draws of test tasks" in kept
    assert kept.count("## TEMP-2D-v0") == 1 and kept.count(make_results.KEPT_NOTE) == 1
    again = make_results.main(["--worlds", "3d", *docs]).read_text()
    assert again.count(make_results.KEPT_NOTE) == 1 and "## TEMP-3D-v0" not in again
    with pytest.raises(SystemExit):
        make_results.main(["--task-draws", "0", *docs])


def test_a_report_written_again_shows_each_tensorboard_step_once(tmp_path):
    """The report is rewritten whole from its records on a rerun; its events used to pile up."""
    pytest.importorskip("tensorboard")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    for _ in range(2):
        write_report(fake_records(), tmp_path, tensorboard=True)
    events = EventAccumulator(str(tmp_path / "tensorboard"))
    events.Reload()
    tag = next(tag for tag in events.Tags()["scalars"] if tag.startswith("success_vs_time/"))
    steps = [event.step for event in events.Scalars(tag)]
    assert steps and len(steps) == len(set(steps))
