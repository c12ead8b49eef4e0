"""Columns edited after generation, with the card's checksums rewritten to match, are refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from temp_gym.config import load_config
from temp_gym.data import generate_dataset, load_split
from temp_gym.data.tables import file_digest
from temp_gym.files import StoredFileError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("built")
    config = load_config(
        ROOT / "configs" / "tiny.yaml", [f"data.dir={directory}", "data.workspaces.val=1"]
    )
    return generate_dataset(config, workers=1, progress=False)


def tampered(built: Path, tmp_path: Path, table: str, column: str, edit) -> Path:
    """A copy of the dataset with one column edited and the card updated to match it."""
    root = tmp_path / "data"
    shutil.copytree(built, root)
    path = root / "train" / table / f"{column}.npy"
    array = np.load(path)
    edit(array)
    np.save(path, array)
    card_path = root / "dataset_card.json"
    card = json.loads(card_path.read_text())
    card["files"][f"train/{table}/{column}.npy"] = file_digest(path)
    card_path.write_text(json.dumps(card))
    return root


def set_first(value):
    def edit(array):
        array.reshape(len(array), -1)[0, 0] = value

    return edit


CASES = {
    "workspace id out of range": ("buffer", "workspace_id", set_first(10**6), "workspace"),
    "path length 0": ("buffer", "path_length", set_first(0), "path_length"),
    "path length beyond L": ("buffer", "path_length", set_first(10**6), "path_length"),
    "NaN target": ("buffer", "target", set_first(np.nan), "NaN"),
    "start outside [-1, 1]": ("buffer", "start", set_first(7.0), "start"),
    "negative goal radius": ("buffer", "goal_radius", set_first(-1.0), "goal_radius"),
    "task id out of range": ("buffer", "task_id", set_first(10**9), "task_id"),
    "occupancy of 0.5": ("workspaces", "occupancy", set_first(0.5), "0 and 1"),
    "repeated workspace ids": ("workspaces", "workspace_id", lambda a: a.fill(0), "repeated"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_column_out_of_range_is_refused_naming_its_file(built, tmp_path, case):
    table, column, edit, words = CASES[case]
    if (
        case == "repeated workspace ids"
        and len(np.load(built / "train" / table / "workspace_id.npy")) < 2
    ):
        pytest.skip("one workspace: no id to repeat")
    root = tampered(built, tmp_path, table, column, edit)
    with pytest.raises(StoredFileError, match=words) as caught:
        load_split(root, "train")
    assert f"{column}.npy" in str(caught.value)


def test_the_untouched_dataset_loads(built):
    buffer, workspaces = load_split(built, "train")
    assert len(buffer) > 0 and len(workspaces) > 0
