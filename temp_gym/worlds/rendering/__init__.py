"""Pictures of problems, trees and paths as ``uint8`` RGB arrays of shape ``(height, width, 3)``.

* `render_point_world` (`temp_gym.worlds.rendering.points`) draws a ``point2d`` or ``point3d``
  problem with matplotlib: obstacles, the planner's tree, a path, the start and the goal region.
* `ArmRenderer` (`temp_gym.worlds.rendering.arm`) draws an arm's problem with pybullet's
  software renderer: the obstacles and the arm at a few configurations, from a camera chosen per
  scene so that the arm is in view.

Obstacles of every kind (boxes, turned or not, cylinders, spheres; discs in 2D) are drawn by
their shape (`temp_gym.worlds.rendering.solids`).

Both tell a solution (bold red in 2D/3D, start-to-goal arms in 7D) from the path so far
before one exists (dashed orange; an orange arm at the newest node), their titles say
which (`plan_title`), and a legend across the bottom names what is drawn.

Examples:
    >>> image = render_point_world(problem, positions=tree.positions, parents=tree.parents,
    ...                            num_nodes=tree.num_nodes, path=tree.best_path())
    >>> image.shape, image.dtype
    ((480, 480, 3), dtype('uint8'))
    >>> with ArmRenderer(arm) as renderer:
    ...     frame = renderer.render(arm_problem, path=result.path)
"""

from __future__ import annotations

from temp_gym.worlds.rendering.arm import ArmRenderer, arm_poses
from temp_gym.worlds.rendering.common import plan_title
from temp_gym.worlds.rendering.points import MAX_3D_EDGES, render_point_world

__all__ = ["MAX_3D_EDGES", "ArmRenderer", "arm_poses", "plan_title", "render_point_world"]
