"""Evaluation of TEMP against RRT*, Informed RRT* and OMPL's planners (the paper's protocol)."""

from temp_gym.evaluation.protocol import (
    TAU,
    aggregate_rows,
    cost_curve,
    markdown_table,
    paired_ratios,
    reach_tolerance,
    success_curve,
    tolerance_target,
)

__all__ = [
    "TAU",
    "aggregate_rows",
    "cost_curve",
    "markdown_table",
    "paired_ratios",
    "reach_tolerance",
    "success_curve",
    "tolerance_target",
]
