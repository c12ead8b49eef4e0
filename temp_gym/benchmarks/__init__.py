"""Benchmark sets made elsewhere, loaded as temp-gym problems.

* `temp_gym.benchmarks.motionbenchmaker`: MotionBenchMaker's Panda problems (MoveIt scenes
  and requests), ``load(path)`` and ``invalid(problems)``.
"""
