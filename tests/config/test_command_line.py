from pathlib import Path

import pytest

from temp_gym.config import checkpoint_entry


def test_a_checkpoint_entry_gives_its_path_and_typed_settings():
    assert checkpoint_entry("runs/a/best.pt") == (Path("runs/a/best.pt"), {})
    path, settings = checkpoint_entry("runs/a/best.pt@noise_std=0.03,horizon=4")
    assert path == Path("runs/a/best.pt") and settings == {"noise_std": 0.03, "horizon": 4}
    assert isinstance(settings["horizon"], int) and isinstance(settings["noise_std"], float)


@pytest.mark.parametrize(
    ("entry", "message"),
    [("a.pt@seed=1", "key of"), ("a.pt@horizon", "key=value"), ("a.pt@horizon=2.5", "int")],
)
def test_a_bad_checkpoint_entry_names_the_flag_and_the_item(entry, message):
    with pytest.raises(ValueError, match=message) as error:
        checkpoint_entry(entry, flag="--policies")
    assert str(error.value).startswith(f"--policies {entry}:")
