"""Every MJCF name the Python code refers to, in one place.

``tests/test_assets.py`` checks that each of them exists in every shipped scene, so a renamed body,
site or sensor in ``assets/`` fails a test instead of a user's run.
"""

from __future__ import annotations

# Bodies and joints.
BASE_BODY = "base_link"
ROOT_JOINT = "root"
LEFT_WHEEL_BODY = "left_wheel"
RIGHT_WHEEL_BODY = "right_wheel"
LEFT_WHEEL_JOINT = "left_wheel_joint"
RIGHT_WHEEL_JOINT = "right_wheel_joint"

# Actuators, in action order (left, right).
LEFT_MOTOR = "left_motor"
RIGHT_MOTOR = "right_motor"

# Sites that are ROS frames (REP 103 orientation), children of base_link.
LASER_SITE = "laser_link"
PROXIMITY_SITE = "proximity_link"
CAMERA_SITE = "camera_link"
# The rangefinder's own site (it measures along its +z axis).
PROXIMITY_RAY_SITE = "proximity_ray"

# Cameras.
FRONT_CAMERA = "front_camera"

# MuJoCo sensors.
PROXIMITY_SENSOR = "proximity"
VELOCIMETER_SENSOR = "base_velocity"
GYRO_SENSOR = "base_gyro"
LEFT_WHEEL_SPEED_SENSOR = "left_wheel_speed"
RIGHT_WHEEL_SPEED_SENSOR = "right_wheel_speed"

# Scene geoms.
FLOOR_GEOM = "floor"
ARENA_WALLS = ("wall_north", "wall_south", "wall_east", "wall_west")
# Prefixes of the obstacle slots the env adds to the scene (suffix: slot index).
CYLINDER_SLOT_PREFIX = "obstacle_cylinder_"
BOX_SLOT_PREFIX = "obstacle_box_"

# Geom groups (see assets/common.xml): the laser sees only OBSTACLE_GROUP.
OBSTACLE_GROUP = 0
FLOOR_GROUP = 1
ROBOT_GROUP = 2

# Default classes in assets/common.xml used for generated obstacles.
OBSTACLE_CLASS = "obstacle"

REQUIRED_NAMES: dict[str, tuple[str, ...]] = {
    "body": (BASE_BODY, LEFT_WHEEL_BODY, RIGHT_WHEEL_BODY),
    "joint": (ROOT_JOINT, LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT),
    "actuator": (LEFT_MOTOR, RIGHT_MOTOR),
    "site": (LASER_SITE, PROXIMITY_SITE, CAMERA_SITE, PROXIMITY_RAY_SITE),
    "camera": (FRONT_CAMERA,),
    "sensor": (
        PROXIMITY_SENSOR,
        VELOCIMETER_SENSOR,
        GYRO_SENSOR,
        LEFT_WHEEL_SPEED_SENSOR,
        RIGHT_WHEEL_SPEED_SENSOR,
    ),
    "geom": (FLOOR_GEOM,),
}
"""Names every scene must define, keyed by MuJoCo object type (as in ``model.body(name)``)."""
