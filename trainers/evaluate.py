"""The paper's evaluation: TEMP vs RRT*, Informed RRT* (and OMPL's) on unseen test tasks.

    python trainers/evaluate.py --config configs/2d.yaml                 # shipped policy
    python trainers/evaluate.py --config configs/7d.yaml --checkpoint runs/.../best.pt

Everything else (settings, outputs, resuming) is `temp_gym.evaluation.command`'s; ``--help``
lists the flags.
"""

import sys

from temp_gym.evaluation.command import main
from temp_gym.jobs import run_script

if __name__ == "__main__":
    sys.exit(run_script("evaluate.py", main))
