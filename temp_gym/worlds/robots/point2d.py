"""``point2d``: a point robot in a 20 x 20 box world (`TEMP-2D-v0`)."""

from temp_gym.worlds.robots.point import point_robot

POINT2D = point_robot(
    name="point2d",
    env_id="TEMP-2D-v0",
    short_name="2d",
    seed_code=0,
    dim=2,
    encoding_resolution=32,
)
