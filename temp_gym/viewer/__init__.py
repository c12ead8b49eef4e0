"""A plan in the browser: the scene, the tree and the path, with viser (``temp-gym[view]``).

| module | what |
|---|---|
| `plan_viewer` | `view_plan` (returns a `PlanViewer` handle), `serve_plan` (until Ctrl-C) |
| `content` | what is drawn, in world coordinates, computed without a browser |
| `drawing` | the viser scene: boxes, tree, path, start, goal, the robot along the path |
| `arm_geometry` | the one door to an arm's model: link meshes and link poses |
| `command` | ``temp-view``: a problem and, optionally, a stored result or path |
| `browser` | headless Chromium screenshots of a page (tests, documentation) |

Only `plan_viewer` and `drawing` import viser, and only when a viewer starts; the names
below are imported on first use, so ``temp-view --help`` stays quick.
"""

__all__ = ["PlanViewer", "serve_plan", "view_plan"]


def __getattr__(name: str):
    if name in __all__:
        from temp_gym.viewer import plan_viewer

        return getattr(plan_viewer, name)
    raise AttributeError(f"module 'temp_gym.viewer' has no attribute {name!r}")
