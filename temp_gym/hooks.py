"""What the package's face hands its lower layers at import, kept where no layer must load.

`import temp_gym` sets `default_policy_loader` to the shipped policies without importing the
planning layer (and numba with it): ``import temp_gym`` and every command's ``--help`` stay
light, and the planning layer, which imports no model code, still finds its default policy
through `temp_gym.planning.temp_planner.default_policy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

robot_file_loader: Callable[[str], Any] | None = None
"""``loader(path)``: register the arm described at ``path`` and return its spec (its name,
``env_id``); `import temp_gym` sets it to `temp_gym.register_robot_file`, so a config can name
an arm by its description file without the config layer loading the worlds."""

described_arms: Callable[[], tuple[str, ...]] | None = None
"""``described_arms()``: the description files of the arms registered in this process beyond
the shipped ones;
`import temp_gym` sets it, and `temp_gym.distributed` hands them to its worker processes."""

default_policy_loader: Callable[[str], Any] | None = None
"""``loader(robot name)``: the policy the ``temp`` planner uses when given none (None: no
default; `temp_gym.planning.temp_planner.set_default_policy` sets it)."""
