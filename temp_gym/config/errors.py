"""The one error of configs."""

from __future__ import annotations

from temp_gym.jobs import JobError


class ConfigError(JobError, ValueError):
    """A config file, key or override that cannot be used; the message names it."""
