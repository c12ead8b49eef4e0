from pathlib import Path

import pytest

from temp_gym.config import labelled_entry
from temp_gym.models.checkpoint_settings import checkpoint_entry


def test_a_checkpoint_entry_gives_its_path_and_typed_settings():
    assert checkpoint_entry("runs/a/best.pt") == (Path("runs/a/best.pt"), {})
    path, settings = checkpoint_entry("runs/a/best.pt@noise_std=0.03,horizon=4")
    assert path == Path("runs/a/best.pt") and settings == {"noise_std": 0.03, "horizon": 4}
    assert isinstance(settings["horizon"], int) and isinstance(settings["noise_std"], float)
    _, settings = checkpoint_entry("a.pt@path_window=16,attention_resume_growth=4")
    assert settings == {"path_window": 16, "attention_resume_growth": 4.0}
    assert isinstance(settings["attention_resume_growth"], float)


@pytest.mark.parametrize(
    ("entry", "message"),
    [("a.pt@seed=1", "key of"), ("a.pt@horizon", "key=value"), ("a.pt@horizon=2.5", "int")],
)
def test_a_bad_checkpoint_entry_names_the_flag_and_the_item(entry, message):
    with pytest.raises(ValueError, match=message) as error:
        checkpoint_entry(entry, flag="--policies")
    assert str(error.value).startswith(f"--policies {entry}:")


def test_a_labelled_entry_splits_at_the_last_equals_sign():
    assert labelled_entry("width 32=runs/a/best.pt") == ("width 32", "runs/a/best.pt")
    assert labelled_entry("lr=1e-4=runs/b.pt") == ("lr=1e-4", "runs/b.pt")
    for entry in ("runs/a/best.pt", "=runs/a/best.pt", "label="):
        with pytest.raises(ValueError, match=r"--policies .*expected LABEL=CHECKPOINT"):
            labelled_entry(entry, flag="--policies")
