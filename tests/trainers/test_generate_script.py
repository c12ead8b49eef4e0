"""trainers/generate.py: what it prints when a split ends up without expert plans."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from trainers import generate  # noqa: E402


def test_a_split_without_expert_plans_is_named_on_stderr(tmp_path, capsys):
    config = str(ROOT / "configs" / "tiny.yaml")
    generate.main(["--config", config, "--no-progress", "data.max_nodes=1",
                   f"data.dir={tmp_path / 'data'}"])  # fmt: skip
    err = capsys.readouterr().err
    for split, plans, workspaces in (("train", 8, "2 workspaces"), ("val", 4, "1 workspace)")):
        assert (f"generate.py: warning: the {split} split stored no expert plan ({plans} of "
                f"{plans} failed, in {workspaces}") in err  # fmt: skip
    assert "data.max_nodes" in err


def test_a_dataset_with_plans_in_every_split_gets_no_warning():
    card = {"splits": {"train": {"plans_stored": 3}, "val": {"plans_stored": 1}}}
    assert generate.empty_split_warnings(card) == []
