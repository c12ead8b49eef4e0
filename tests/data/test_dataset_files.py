"""A dataset on disk meets hostile or damaged files: no pickle runs, damage is named, locks hold."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from temp_gym.config import load_config
from temp_gym.data import dataset_exists, generate_dataset, load_split, load_tasks
from temp_gym.data.dataset import load_workspaces
from temp_gym.data.generate import read_unit, unit_path
from temp_gym.data.tables import file_digest
from temp_gym.files import DirectoryLock, LockedError, StoredFileError

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "configs" / "tiny.yaml"


def tiny(directory: Path, *overrides: str) -> dict:
    return load_config(TINY, [f"data.dir={directory}", "data.workspaces.val=1", *overrides])


class Payload:
    """Unpickling this creates ``marker``: proof that a pickle ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("built")
    return generate_dataset(tiny(directory), workers=1, progress=False)


@pytest.fixture
def dataset(built, tmp_path) -> Path:
    """A fresh copy of the built dataset that a test may damage."""
    copy = tmp_path / "data"
    shutil.copytree(built, copy)
    return copy


def card_of(root: Path) -> dict:
    return json.loads((root / "dataset_card.json").read_text())


def list_in_card(root: Path, path: Path) -> None:
    """Tamper with the card too, so that it vouches for ``path`` (an attacker controls both)."""
    card = card_of(root)
    card["files"][path.relative_to(root).as_posix()] = file_digest(path)
    (root / "dataset_card.json").write_text(json.dumps(card))


def test_the_payload_runs_when_unpickled(tmp_path):
    # The proof the tests below rely on: this payload does create its marker.
    marker = tmp_path / "ran"
    pickle.loads(pickle.dumps(Payload(marker)))
    assert marker.exists()


def test_a_planted_prefetch_pickle_is_refused_and_never_run(dataset, tmp_path):
    marker = tmp_path / "ran"
    planted = dataset / "train" / "buffer" / "prefetch.pkl"
    planted.write_bytes(pickle.dumps(Payload(marker)))
    with pytest.raises(StoredFileError, match="prefetch.pkl.*does not list it"):
        load_split(dataset, "train")
    list_in_card(dataset, planted)  # even when the card lists it, nothing reads it
    buffer, _ = load_split(dataset, "train")
    assert len(buffer) > 0
    assert not marker.exists()


@pytest.mark.parametrize("table", ["buffer", "workspaces", "tasks"])
def test_a_pickled_column_is_refused_and_never_run(dataset, tmp_path, table):
    marker = tmp_path / "ran"
    column = next((dataset / "train" / table).glob("*.npy"))
    np.save(column, np.array([Payload(marker)] * 2, dtype=object), allow_pickle=True)
    with pytest.raises(StoredFileError, match=rf"{column.name}: .*(bytes where|SHA-256)"):
        load_split(dataset, "train") if table != "tasks" else load_tasks(dataset, "train")
    list_in_card(dataset, column)  # the card vouches for it: still never unpickled
    with pytest.raises(StoredFileError, match=f"{column.name}.*not a readable array"):
        load_split(dataset, "train") if table != "tasks" else load_tasks(dataset, "train")
    assert not marker.exists()


def test_a_truncated_buffer_file_is_named_and_left_as_it_is(dataset):
    target = dataset / "train" / "buffer" / "target.npy"
    size = target.stat().st_size
    with open(target, "r+b") as handle:
        handle.truncate(size // 2)
    with pytest.raises(StoredFileError, match=r"target\.npy: .* bytes where the dataset card says"):
        load_split(dataset, "train")
    assert target.stat().st_size == size // 2  # never re-extended
    assert not dataset_exists(tiny(dataset))


def test_a_flipped_byte_is_caught_by_the_checksum(dataset):
    occupancy = dataset / "train" / "workspaces" / "occupancy.npy"
    data = bytearray(occupancy.read_bytes())
    data[-1] ^= 0xFF
    occupancy.write_bytes(bytes(data))
    with pytest.raises(StoredFileError, match=r"occupancy\.npy: its SHA-256 differs"):
        load_workspaces(dataset, "train")


def test_a_dataset_of_the_old_format_says_how_to_regenerate(dataset):
    card = card_of(dataset)
    del card["format"], card["files"]
    (dataset / "dataset_card.json").write_text(json.dumps(card))
    with pytest.raises(StoredFileError, match="older temp-gym.*rerun trainers/generate.py"):
        load_split(dataset, "train")


def _damage_card(dataset, change):
    card = card_of(dataset)
    (dataset / "dataset_card.json").write_text(json.dumps(change(card)))


def _first_entry(card):
    return card["files"][next(iter(card["files"]))]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda card: [], "not a JSON object"),
        (lambda card: "a card", "not a JSON object"),
        (lambda card: {k: v for k, v in card.items() if k != "files"}, "no 'files' list"),
        (lambda card: {**card, "files": []}, "no 'files' list"),
        (lambda card: {**card, "files": dict.fromkeys(card["files"])}, "needs an integer"),
        (lambda card: (_first_entry(card).pop("bytes"), card)[1], "needs an integer 'bytes'"),
        (lambda card: (_first_entry(card).update(bytes="1016"), card)[1], "needs an integer"),
        (lambda card: (_first_entry(card).pop("sha256"), card)[1], "a 'sha256'"),
        (lambda card: {**card, "format": 3}, "newer temp-gym .format 3"),
        (lambda card: {**card, "format": "2"}, r"damaged \(format '2'"),
    ],
)
def test_a_damaged_or_foreign_card_is_named_in_one_error(dataset, change, message):
    _damage_card(dataset, change)
    with pytest.raises(StoredFileError, match=message) as caught:
        load_split(dataset, "train")
    assert "dataset_card.json" in str(caught.value)
    assert not dataset_exists(tiny(dataset))


def test_a_missing_table_is_not_done_and_is_repaired(dataset):
    before = load_tasks(dataset, "val")["task_id"].clone()
    samples = load_split(dataset, "train")[0][:]["target"].clone()
    shutil.rmtree(dataset / "val" / "tasks")
    shutil.rmtree(dataset / "train" / "buffer")
    config = tiny(dataset)
    assert not dataset_exists(config)
    generate_dataset(config, workers=1, progress=False)  # rebuilt from the stored units
    assert dataset_exists(config)
    assert torch.equal(load_tasks(dataset, "val")["task_id"], before)
    assert torch.equal(load_split(dataset, "train")[0][:]["target"], samples)


@pytest.mark.parametrize("damage", ["truncate", "empty", "garbage"])
def test_a_damaged_unit_is_named_with_what_to_do(dataset, damage):
    path = unit_path(dataset, "train", 1)
    content = path.read_bytes()
    path.write_bytes(
        {"truncate": content[: len(content) // 2], "empty": b""}.get(damage, b"x" * 99)
    )
    with pytest.raises(StoredFileError, match=r"001\.npz: .*delete it and rerun"):
        read_unit(path)
    (dataset / "dataset_card.json").unlink()  # a rerun that must read the units
    with pytest.raises(StoredFileError, match=r"001\.npz"):
        generate_dataset(tiny(dataset), workers=1, progress=False)


def test_a_damaged_settings_file_is_named(dataset):
    (dataset / "settings.json").write_text('{"robot": "poi')
    with pytest.raises(StoredFileError, match=r"settings\.json: damaged"):
        generate_dataset(tiny(dataset), workers=1, progress=False)


def test_a_second_run_on_a_locked_directory_is_refused_naming_the_holder(dataset):
    lock = DirectoryLock(dataset, "a test holding the lock")
    lock.acquire()
    try:
        with pytest.raises(LockedError, match=f"pid {os.getpid()}.*a test holding the lock"):
            generate_dataset(tiny(dataset), workers=1, progress=False)
    finally:
        lock.release()
    generate_dataset(tiny(dataset), workers=1, progress=False)  # free again


def test_the_lock_of_a_killed_run_is_not_stale(tmp_path):
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from temp_gym.files import DirectoryLock; "
            f"lock = DirectoryLock({str(tmp_path)!r}, 'killed'); lock.acquire(); "
            "print('held', flush=True); "
            "time.sleep(60)",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert holder.stdout.readline().strip() == "held"
    assert DirectoryLock(tmp_path, "second").is_held_elsewhere()
    os.kill(holder.pid, signal.SIGKILL)
    holder.wait()
    with DirectoryLock(tmp_path, "second"):  # no stale lock left behind
        assert "second" in (tmp_path / ".lock").read_text()


def test_an_old_format_dataset_is_rebuilt_by_generate_without_running_its_pickles(
    dataset, tmp_path
):
    marker = tmp_path / "ran"
    card = card_of(dataset)
    del card["format"], card["files"]
    (dataset / "dataset_card.json").write_text(json.dumps(card))
    old = dataset / "train" / "buffer" / "prefetch.pkl"  # what torchrl's dumps wrote
    old.write_bytes(pickle.dumps(Payload(marker)))
    generate_dataset(tiny(dataset), workers=1, progress=False)
    assert not old.exists() and not marker.exists()
    assert card_of(dataset)["format"] == 2 and len(load_split(dataset, "train")[0]) > 0
