"""The KUKA LBR iiwa 14's model: what the iiwa's checkers, generator and renderer build on.

| module | what |
|---|---|
| `kinematics` | the URDF (``kuka_iiwa/model.urdf``), joint limits, meshes, kinematics |
| `convex_hulls` | the links' convex hulls, padded like pybullet's (self-collision geometry) |
| `sphere_fit` | spheres covering each link's hull (``spheres.json``), for the fast checker |
| `acm` | the allowed-collision matrix (``acm.json``): which link pairs are checked |
| `pair_tables` | clearance tables of the pairs two joints apart (``pair_tables.json``) |

Each JSON has its regeneration script (``python -m temp_gym.worlds.iiwa14.acm`` etc.); the
checkers only load them. The robot's spec, which ties this model to the rest of the library,
is `temp_gym.worlds.robots.kuka_iiwa14`.
"""
