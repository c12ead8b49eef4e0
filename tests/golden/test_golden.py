"""Same seeds, same results: what the library computes matches the fingerprints stored from
the code before the renovation (issue 17; see ``golden.py``)."""

import json

import pytest
from golden import STORED, dataset, differences, env_trees, evaluation_records, plans, problems

STORED_FINGERPRINTS = json.loads(STORED.read_text())


@pytest.fixture(scope="module")
def found():
    return problems()


def _check(section: str, computed: dict[str, str]) -> None:
    assert computed, section
    assert differences({section: computed}, STORED_FINGERPRINTS) == []


def test_problems_are_drawn_as_before(found):
    from golden import digest

    _check("problems", {name: digest(problem.to_dict()) for name, problem in found.items()})


def test_every_planner_grows_the_same_trees(found):
    _check("plans", plans(found))


def test_evaluation_records_are_the_same(found):
    _check("evaluation", evaluation_records(found))


def test_env_episodes_step_the_same_trees():
    _check("env", env_trees())


def test_the_tiny_dataset_is_identical_column_for_column():
    _check("dataset", dataset())
