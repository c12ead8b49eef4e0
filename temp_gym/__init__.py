"""temp-gym: sampling-based motion planning as Gymnasium environments, and TEMP."""

from temp_gym.problem import ROBOTS, Problem

__all__ = ["ROBOTS", "Problem"]
__version__ = "0.1.0"
