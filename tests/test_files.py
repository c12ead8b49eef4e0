"""Atomic, fsynced writes for everything a job resumes from; damage-aware reads."""

import json

import pytest

from temp_gym import files
from temp_gym.files import StoredFileError, atomic_write, read_json


@pytest.fixture
def calls(monkeypatch):
    """Record fsync and replace in order (both still run)."""
    seen = []
    fsync, replace = files.os.fsync, files.os.replace

    def record_fsync(descriptor):
        seen.append("fsync")
        fsync(descriptor)

    def record_replace(source, target):
        seen.append(("replace", str(target)))
        replace(source, target)

    monkeypatch.setattr(files.os, "fsync", record_fsync)
    monkeypatch.setattr(files.os, "replace", record_replace)
    return seen


def test_checkpoints_and_evaluation_records_are_fsynced_before_their_rename(tmp_path, calls):
    from temp_gym.evaluation.runner import RECORD_JSON
    from temp_gym.models.temp import TEMPModel

    model = TEMPModel.from_config({"num_layers": 1}, "point2d", 8, 8)
    model.save(tmp_path / "last.pt")
    files.write_json_atomic(tmp_path / "record.json", {"a": 1}, **RECORD_JSON)
    for target in ("last.pt", "record.json"):
        index = calls.index(("replace", str(tmp_path / target)))
        assert calls[index - 1] == "fsync" and calls[index + 1] == "fsync"  # file, directory
    assert json.loads((tmp_path / "record.json").read_text()) == {"a": 1}


def test_the_json_writer_takes_numpy_scalars_and_json_options(tmp_path):
    import numpy as np

    path = tmp_path / "card.json"
    files.write_json_atomic(path, {"b": np.float32(0.5), "a": np.int64(3)})
    assert path.read_text() == '{\n  "a": 3,\n  "b": 0.5\n}'
    files.write_json_atomic(path, {"b": 1, "a": 2}, indent=None, sort_keys=False)
    assert path.read_text() == '{"b": 1, "a": 2}'
    with pytest.raises(ValueError):
        files.write_json_atomic(path, {"a": float("nan")}, allow_nan=False)
    with pytest.raises(TypeError):
        files.write_json_atomic(path, {"a": object()})


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "record.json"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(path, "w") as handle:
            handle.write("new, half")
            raise RuntimeError("killed")
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["record.json"]


@pytest.mark.parametrize(
    "content, problem", [("", "empty"), ('{"a": 1', "damaged, not valid JSON"), (None, "missing")]
)
def test_read_json_names_the_file_and_the_remedy(tmp_path, content, problem):
    path = tmp_path / "run.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(StoredFileError, match=rf"run\.json: {problem}.*; delete it"):
        read_json(path, "delete it")


def test_a_waiting_lock_enters_once_the_holder_releases(tmp_path):
    import threading
    import time

    from temp_gym.files import DirectoryLock, LockedError

    holder = DirectoryLock(tmp_path, "the first run")
    holder.acquire()
    with pytest.raises(LockedError, match="the first run"), DirectoryLock(tmp_path, "second"):
        pass
    order = []

    def release_later():
        time.sleep(0.2)
        order.append("released")
        holder.release()

    thread = threading.Thread(target=release_later)
    thread.start()
    with DirectoryLock(tmp_path, "second", wait=True) as waiting:
        order.append("entered")
        assert DirectoryLock(tmp_path, "test").is_held_elsewhere()
        assert waiting.holder().endswith("second")
    thread.join()
    assert order == ["released", "entered"]
