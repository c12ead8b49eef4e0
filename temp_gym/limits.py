"""The supported sizes: every limit on what a user may hand temp-gym, in one place.

Each input that could make a process allocate or compute without bound (a problem file, a
config, a checkpoint, a dataset, an env argument) is checked against these numbers before the
work it would size begins, and refused past them with a one-line error that names the field,
the value and the limit. ``docs/security.md`` lists them for users; a test reads this module
so that the page and the code cannot drift apart.

The limits are far above what the shipped worlds, configs and policies use (the paper's
worlds have tens of boxes, its models a few hundred thousand weights); they exist so that a
mistyped or hostile value gets an error instead of a hang, an exhausted memory or a crash.
"""

from __future__ import annotations

MAX_PROBLEM_BYTES = 16 * 2**20
"""Largest problem file `temp_gym.problem.Problem.load` reads (16 MiB). A problem at
`MAX_OBSTACLES` boxes takes a few MB even indented; parsing a file this size stays under a
few hundred MB of memory."""

MAX_OBSTACLES = 10_000
"""Most boxes in one problem or workspace. Every collision query of a point robot tests each
box, and the arm's broad phase is built over them, so preparation and search time grow with
the count; at this count both stay well inside a second per query batch."""

MAX_ENCODING_CELLS = 2**18
"""Most cells of the occupancy grid (``encoding_resolution ** workspace dimensions``): 512 per
axis in 2D, 64 in 3D. The EISE's first layer has one weight per cell and hidden unit."""

MIN_ENCODING_RESOLUTION = 2
"""Fewest cells per axis of the occupancy grid."""

MAX_PATH_LENGTH = 4096
"""Most rows L of the path-so-far observation (and of the model's HPD tokens)."""

MAX_MODEL_PARAMETERS = 32 * 2**20
"""Most weights of a `temp_gym.models.TEMPModel` (128 MiB as float32); the shipped ones hold
well under a million. A model config is checked against it before anything is allocated."""

MAX_WEIGHT_MAGNITUDE = 1e6
"""Largest magnitude of a weight in a checkpoint or snapshot: trained weights are a few units
at most (gradients are clipped); beyond this, training diverged or the file was damaged."""

MAX_MODEL_WIDTH = 8192
"""Largest width of any layer of the model (``token_dim``, ``ffn_dim``, ``eise_hidden``)."""

MAX_MODEL_LAYERS = 64
"""Most transformer layers (``num_layers``) and attention heads (``num_heads``)."""

MAX_SEI_TOKENS = 256
"""Most SEI tokens the EISE makes of a workspace (``num_sei_tokens``)."""

MAX_CHUNK = 256
"""Most nodes the MPT predicts per call (``model.chunk``)."""

MAX_CHECKPOINT_BYTES = 512 * 2**20
"""Largest checkpoint file read (512 MiB: a ``last.pt`` of the largest model, its optimizer
state included). Only a regular file is read, so a device without end (``/dev/zero``) is
refused before a byte is read."""

MAX_SNAPSHOT_BYTES = 256 * 2**20
"""Largest inference snapshot (``*.kernels.npz``) read: the weights of the largest model."""

MAX_CONFIG_BYTES = 1 * 2**20
"""Largest YAML config file read (1 MiB)."""

MAX_CONFIG_DEPTH = 32
"""Deepest nesting of mappings and lists in a YAML config or an override's value. YAML
anchors and aliases are refused outright, so a small file cannot expand into a huge value."""

MAX_YAML_NODES = 10_000_000
"""Most mappings, lists and values a robot description or MoveIt scene (YAML) may expand to,
aliases expanded: a few aliases nested can stand for billions of values, which no reader would
finish walking. A file of `MAX_PROBLEM_BYTES` holds a few million without aliases."""

MAX_YAML_DEPTH = 100
"""Deepest nesting, through aliases, of a robot description or MoveIt scene (MoveIt's messages
nest about ten deep)."""

MAX_TASKS_PER_WORKSPACE = 100_000
"""Most start-goal pairs per workspace of a dataset (``data.tasks_per_workspace``; the paper's
is 200)."""

MAX_TASKS = 1_000_000
"""Most tasks of an evaluation or a comparison (``train_eval.tasks``, ``evaluation.tasks``,
``temp-benchmark --split``)."""

MAX_WORKERS = 1024
"""Most worker processes of a job."""

MAX_BATCH_SIZE = 2**20
"""Largest training batch (``train.batch_size``)."""

MAX_EPOCHS = 1_000_000
"""Most training epochs (``train.max_epochs``)."""

MAX_COUNT = 2**40
"""Largest value of any other count a user sets (node budgets, seeds, patiences): large enough
never to bind a real run, small enough that no array sized by it is attempted."""

MAX_NAME_LENGTH = 100
"""Longest run or experiment name (``train.exp_name``): it is one component of a path."""

NAME_CHARACTERS = "letters, digits, '.', '_' and '-' (not starting with '.')"
"""The characters a run or experiment name may hold, in words, for messages and the docs."""

MAX_MESSAGE_VALUE = 80
"""Most characters of a user's value quoted in an error message; a longer one is cut."""

MAX_MESSAGE_LENGTH = 600
"""Most characters of a one-line error message a command prints."""
