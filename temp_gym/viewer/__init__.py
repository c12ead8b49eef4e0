"""A plan in the browser: the scene, the tree and the path, with viser (``temp-gym[view]``).

| module | what |
|---|---|
| `plan_viewer` | `view_plan` (returns a `PlanViewer` handle), `serve_plan` (until Ctrl-C) |
| `content` | what is drawn, in world coordinates, computed without a browser |
| `drawing` | the viser scene: boxes, tree, path, start, goal, the robot along the path |
| `arm_geometry` | the one door to an arm's model: link meshes and link poses |
| `command` | ``temp-view``: a problem and, optionally, a stored result or path |
| `browser` | headless Chromium screenshots of a page (tests, documentation) |

Only `plan_viewer` and `drawing` import viser, and only when a viewer starts, so importing
this package costs nothing without the extra.
"""

from temp_gym.viewer.plan_viewer import PlanViewer, serve_plan, view_plan

__all__ = ["PlanViewer", "serve_plan", "view_plan"]
