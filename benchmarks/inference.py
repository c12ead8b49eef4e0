"""MPT inference time per sample on one CPU core, PyTorch against FastMPT (numba).

    python benchmarks/inference.py                       # 2D, 3D and 7D defaults
    python benchmarks/inference.py --config configs/7d.yaml
    python benchmarks/inference.py --plan                # also: TEMP planning time per node

Measures what `TEMPPolicy.__call__` costs in a planning step: one MPT forward pass (the SEI
is cached per workspace), batch 1, for short and full-length paths, with the PyTorch model and
with `temp_gym.models.fast_mpt.FastMPT` on the same weights and inputs, side by side; then
the whole policy call with each backend, the batched PyTorch throughput (training and
evaluation batches) and the one-off EISE cost per workspace (PyTorch against
`temp_gym.models.fast_eise.FastEISE`, warm and with cold caches). Also prints parameter counts and
the checkpoint size. One thread throughout: ``torch.set_num_threads(1)``,
``NUMBA_NUM_THREADS=1`` and ``OPENBLAS_NUM_THREADS=1`` (the BLAS numba calls); each time is
the best of many short rounds, so that other jobs on the machine disturb it little.

``--plan`` times whole TEMP planning runs (`temp_gym.planning.plan`) of a randomly initialised
2D model with each backend on generated challenging problems: the attention-based phase's
wall time per tree node, the part of it spent in the policy, and RRT*'s and Informed RRT*'s
time per node on the same problems. A random model plans badly, so compare the time per node,
not the totals.
"""

from __future__ import annotations

import os

for _variable in ("NUMBA_NUM_THREADS", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # before numpy, numba and torch load

import io  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402
from temp_planner import TimedPolicy  # noqa: E402  (benchmarks/temp_planner.py)

from temp_gym.config import Config, load_config, parse_args, script_parser  # noqa: E402
from temp_gym.models.fast_eise import FastEISE  # noqa: E402
from temp_gym.models.fast_mpt import FastMPT  # noqa: E402
from temp_gym.models.policy import TEMPPolicy  # noqa: E402
from temp_gym.models.temp import TEMPModel  # noqa: E402
from temp_gym.training import make_model  # noqa: E402


def _time(function, repeats: int, rounds: int = 20) -> float:
    """Best seconds per call over ``rounds`` rounds of ``repeats`` calls (after a warm-up)."""
    for _ in range(max(repeats // 10, 5)):
        function()
    best = np.inf
    for _ in range(rounds):  # the best round: robust to a noisy machine
        began = time.perf_counter()
        for _ in range(repeats):
            function()
        best = min(best, (time.perf_counter() - began) / repeats)
    return best


def _model(config: Config, seed: int = 0) -> TEMPModel:
    torch.manual_seed(seed)
    return make_model(config).eval()


def benchmark(config_path: str, repeats: int, overrides: list[str] | None = None) -> None:
    """Print the per-sample table of one config's default model (sizes overridable)."""
    config = load_config(config_path, overrides)
    model = _model(config)
    dim, length = model.dim, model.max_path_length
    grid = torch.zeros(1, *model.eise.grid_shape)
    buffer = io.BytesIO()
    torch.save(model.checkpoint(), buffer)
    print(
        f"\n{config.env.id}: parameters {model.num_parameters():,} (EISE "
        f"{model.num_parameters('eise'):,}, MPT {model.num_parameters('mpt'):,}), "
        f"checkpoint {buffer.tell() / 1e6:.2f} MB"
    )
    fast = FastMPT(model.mpt)
    rng = np.random.default_rng(0)
    with torch.inference_mode():
        sei = model.eise(grid)
        goal = torch.tensor(rng.uniform(-1, 1, (1, dim)), dtype=torch.float32)
        start = torch.tensor(rng.uniform(-1, 1, (1, dim)), dtype=torch.float32)
        radius = torch.full((1, 1), 0.05)
        prefix = fast.prefix(sei.numpy(), goal.numpy(), 0.05, start.numpy())
        print("  MPT batch 1, one sample (us)")
        print(f"  {'path nodes':>10} | {'torch':>8} | {'numba':>8} | {'torch/numba':>11}")
        for rows in sorted({1, 8, 16, 32, length}):
            path = torch.tensor(rng.uniform(-1, 1, (1, rows, dim)), dtype=torch.float32)
            rows_tensor = torch.tensor([rows])
            torch_seconds = _time(
                lambda p=path, n=rows_tensor: model.mpt(sei, goal, radius, start, p, n),
                max(repeats // 10, 10),
            )
            path_array = path[0].numpy()
            numba_seconds = _time(lambda p=path_array, n=rows: fast.predict(prefix, p, n), repeats)
            print(
                f"  {rows:>10} | {torch_seconds * 1e6:>8.1f} | {numba_seconds * 1e6:>8.1f} | "
                f"{torch_seconds / numba_seconds:>10.1f}x"
            )
        _policy_calls(model, repeats)
        batch = 256
        sei_b = sei.expand(batch, -1, -1)
        path = torch.rand(batch, length, dim) * 2 - 1
        lengths = torch.randint(1, length + 1, (batch,))
        goal_b, start_b, radius_b = (
            goal.expand(batch, -1),
            start.expand(batch, -1),
            radius.expand(batch, -1),
        )
        seconds = _time(
            lambda: model.mpt(sei_b, goal_b, radius_b, start_b, path, lengths),
            max(repeats // 100, 2),
            rounds=5,
        )
        print(f"  MPT torch batch {batch}, mixed lengths: {seconds / batch * 1e6:.1f} us/sample")
    _eise_calls(model, repeats)


def _eise_calls(model: TEMPModel, repeats: int) -> None:
    """EISE once per workspace: PyTorch against `FastEISE`, warm and with cold caches.

    In a planning loop the EISE runs after a whole plan has pushed its weights out of the
    cache, so the cold time (a 64 MB buffer written before each call) is the one planning pays.
    """
    from temp_gym.worlds.encoding import occupancy_grid
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem(model.robot, np.random.default_rng(0), "challenging")
    grid = occupancy_grid(problem.workspace, model.encoding_resolution)
    tensor = torch.from_numpy(grid).unsqueeze(0)
    fast = FastEISE(model.eise)
    calls = {"torch": lambda: model.eise(tensor), "FastEISE": lambda: fast(grid)}
    evict = np.zeros(8_000_000)
    print(f"  EISE once per workspace (us), {grid.mean():.0%} of the cells occupied")
    print(f"  {'':>10} | {'warm':>8} | {'cold':>8}")
    with torch.inference_mode():
        for name, call in calls.items():
            warm = _time(call, max(repeats // 20, 5), rounds=5)
            cold = []
            for _ in range(max(repeats // 20, 20)):
                evict += 1.0
                began = time.perf_counter()
                call()
                cold.append(time.perf_counter() - began)
            print(f"  {name:>10} | {warm * 1e6:>8.1f} | {np.median(cold) * 1e6:>8.1f}")


def _policy_calls(model: TEMPModel, repeats: int) -> None:
    """`TEMPPolicy.__call__` with each backend on an observation with a 16-node path."""
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem(model.robot, np.random.default_rng(0))
    rows = 16
    path = np.zeros((model.max_path_length, model.dim), np.float32)
    path[:rows] = np.random.default_rng(1).uniform(-1, 1, (rows, model.dim))
    observation = {"path": path, "path_length": np.array([rows])}
    seconds = {}
    for backend in ("torch", "numba"):
        policy = TEMPPolicy(model, noise_std=0.03, seed=0, backend=backend)
        policy.reset(problem)
        count = max(repeats // 10, 10) if backend == "torch" else repeats
        seconds[backend] = _time(lambda p=policy: p(observation), count)
    print(
        f"  TEMPPolicy call (path {rows}, noise): torch {seconds['torch'] * 1e6:.1f} us, "
        f"numba {seconds['numba'] * 1e6:.1f} us ({seconds['torch'] / seconds['numba']:.1f}x)"
    )


def plan_per_node(config_path: str, problems: int, nodes: int, rounds: int) -> None:
    """Print TEMP's attention-phase time per node with each backend, and RRT*'s."""
    from temp_gym.planning import plan
    from temp_gym.worlds.generators import generate_problem

    config = load_config(config_path)
    model = _model(config)
    robot = config.env.robot
    rng = np.random.default_rng(1)
    tasks = [generate_problem(robot, rng, "challenging") for _ in range(problems)]
    print(
        f"\nTEMP planning, randomly initialised {config.env.id} model, {problems} "
        f"challenging problems, attention phase up to {nodes} nodes (best of {rounds} rounds)"
    )
    print(
        f"  {'planner':>22} | {'nodes':>6} | {'us/node':>8} | {'policy us/call':>14} | "
        f"{'rest us/node':>12}"
    )
    noise = config.train_eval.noise_std or 0.0
    for backend in ("torch", "numba"):
        policy = TimedPolicy(TEMPPolicy(model, noise_std=noise, seed=0, backend=backend))
        plan(tasks[0], planner="temp", policy=policy, seed=0, max_nodes=nodes)  # warm-up
        total_nodes, total_seconds, policy_seconds, calls = 0, 0.0, 0.0, 0
        for index, task in enumerate(tasks):
            best = None
            for _ in range(rounds):
                policy.seconds, policy.calls = 0.0, 0
                result = plan(
                    task,
                    planner="temp",
                    policy=policy,
                    seed=index,
                    max_nodes=nodes,
                    attention_nodes=nodes,
                    stop_at_first=True,
                )
                run = (result.attention["time"], policy.seconds, policy.calls)
                best = run if best is None or run[0] < best[0] else best
            total_nodes += result.attention["nodes"]
            total_seconds += best[0]
            policy_seconds += best[1]
            calls += best[2]
        per_node = total_seconds / total_nodes
        per_call = policy_seconds / max(calls, 1)
        rest = (total_seconds - policy_seconds) / total_nodes
        print(
            f"  {'temp (' + backend + ')':>22} | {total_nodes:>6} | {per_node * 1e6:>8.1f} | "
            f"{per_call * 1e6:>14.1f} | {rest * 1e6:>12.1f}"
        )
    for planner in ("rrt_star", "informed_rrt_star"):
        plan(tasks[0], planner=planner, seed=0, max_nodes=nodes)  # warm-up
        total_nodes, total_seconds = 0, 0.0
        for index, task in enumerate(tasks):
            runs = [plan(task, planner=planner, seed=index, max_nodes=nodes) for _ in range(rounds)]
            total_nodes += runs[0].nodes
            total_seconds += min(run.wall_time for run in runs)
        print(
            f"  {planner:>22} | {total_nodes:>6} | {total_seconds / total_nodes * 1e6:>8.1f} | "
            f"{'':>14} | {'':>12}"
        )


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.split("\n")[0])
    parser.add_argument("--config", action="append", help="config file(s); default: all worlds")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--repeats", type=int, default=200, help="calls per timing round")
    parser.add_argument("--plan", action="store_true", help="also time TEMP planning per node")
    parser.add_argument(
        "--plan-config", default="configs/2d.yaml", help="--plan: config of the planned world"
    )
    parser.add_argument("--plan-problems", type=int, default=5, help="--plan: generated problems")
    parser.add_argument("--plan-nodes", type=int, default=500, help="--plan: nodes per plan")
    parser.add_argument("--plan-rounds", type=int, default=3, help="--plan: timing rounds")
    parser.add_argument(
        "overrides", nargs="*", help="key=value config overrides, e.g. model.token_dim=32"
    )
    args = parse_args(parser, argv)
    torch.set_num_threads(args.threads)
    print(
        f"torch {torch.__version__}, {args.threads} torch thread(s); NUMBA_NUM_THREADS="
        f"{os.environ['NUMBA_NUM_THREADS']}, OPENBLAS_NUM_THREADS="
        f"{os.environ['OPENBLAS_NUM_THREADS']}"
    )
    for path in args.config or ["configs/2d.yaml", "configs/3d.yaml", "configs/7d.yaml"]:
        benchmark(path, args.repeats, args.overrides)
    if args.plan:
        plan_per_node(args.plan_config, args.plan_problems, args.plan_nodes, args.plan_rounds)


if __name__ == "__main__":
    main()
