"""Evaluation of TEMP against RRT*, Informed RRT* and OMPL's planners (the paper's protocol)."""

from temp_gym.evaluation.protocol import (
    TAU,
    aggregate_rows,
    cost_curve,
    distribution_rows,
    distribution_table,
    markdown_table,
    paired_ratio_statistics,
    paired_ratios,
    reach_tolerance,
    success_curve,
    success_label,
    tolerance_target,
)
from temp_gym.evaluation.statistics import bootstrap_interval, describe

__all__ = [
    "TAU",
    "aggregate_rows",
    "bootstrap_interval",
    "cost_curve",
    "describe",
    "distribution_rows",
    "distribution_table",
    "markdown_table",
    "paired_ratio_statistics",
    "paired_ratios",
    "reach_tolerance",
    "success_curve",
    "success_label",
    "tolerance_target",
]
