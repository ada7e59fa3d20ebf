"""BubbleRob, the CoppeliaSim tutorial robot (``BubbleRob-v0``).

Its dimensions are those of ``assets/bubblerob.xml`` (written there once, with the masses and
motors); what the Python code needs of them is here. The values are the ones the env had before
robots were data: BubbleRob's episodes and recorded bags are bit for bit those of before.
"""

from __future__ import annotations

import math

from bubblerob_env.robots.description import (
    ASSETS_DIR,
    ArenaDefaults,
    LaserDefaults,
    ProximityDefaults,
    RobotDescription,
)

__all__ = ["BUBBLEROB"]

BUBBLEROB = RobotDescription(
    name="bubblerob",
    title="BubbleRob",
    env_id="BubbleRob-v0",
    robot_file=ASSETS_DIR / "bubblerob.xml",
    scene_file=ASSETS_DIR / "arena.xml",
    # The wheels' outer rims reach 0.108 m from base_link, rounded up; tests/test_assets.py
    # checks it against the compiled geoms.
    radius=0.11,
    max_wheel_speed=10.0,  # 0.4 m/s at the 0.04 m rim
    # A 360-degree scanner, one ray a degree, 5 m: a small hobby lidar's reach at this size.
    # The window: the housing's radius, 2.5 cm tall about the laser's plane (0.18 m), the only
    # part of a BubbleRob at that height (the chassis ends at 0.165 m).
    laser=LaserDefaults(
        num_rays=360, fov=2.0 * math.pi, range_min=0.05, range_max=5.0, window=(0.025, 0.0125)
    ),
    # The tutorial's FrontUS: an ultrasonic sensor on the nose; sensorTrigger under 0.3 m.
    proximity=ProximityDefaults(range_max=0.6, trigger_distance=0.3),
    arena=ArenaDefaults(
        size=4.0,
        num_obstacles=(4, 10),
        obstacle_size=(0.08, 0.25),
        start_clearance=0.25,
        clearance_distance=0.35,
    ),
)
