"""``point3d``: a point robot in a 20 x 20 x 20 box world (`TEMP-3D-v0`)."""

from temp_gym.worlds.robots.point import point_robot

POINT3D = point_robot(
    name="point3d",
    env_id="TEMP-3D-v0",
    short_name="3d",
    seed_code=1,
    dim=3,
    encoding_resolution=16,
)
