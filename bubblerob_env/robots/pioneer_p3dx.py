"""The Pioneer 3-DX of the third tutorial (``PioneerP3DX-v0``): camera, 2D laser, ``/vrep/`` topics.

Where each number comes from:

- Body 0.455 m long, 0.381 m wide over the tyres, 0.237 m tall; 9 kg; wheels 0.195 m across;
  1.2 m/s top speed; 300 degrees/s top yaw rate: the Pioneer 3-DX datasheet (Adept
  MobileRobots, "Pioneer 3-DX", 2011: length 455 mm, width 381 mm, height 237 mm, weight 9 kg,
  wheel diameter 195 mm, max. forward/backward speed 1.2 m/s, rotation speed 300 deg/s), the
  figures issue #26 quotes.
- Track 0.33 m between the wheels' centres (wheel radius 0.0975 m, half-axle 0.165 m): the
  Webots ``Pioneer3dx`` robot definitions use these; ARIA's ``DiffConvFactor`` (1 / half the
  axle in mm) gives 0.357 m for the older P2-DX. The tyres' half-width, 0.0255 m, is what
  makes the datasheet's 0.381 m width over the tyres with that track.
- The axle 4 cm ahead of the body's centre: Stage's ``pioneer.inc`` offsets Pioneers' centre of
  rotation by -0.04 m (``offset [-0.04 0.0]``).
- Rear caster 0.075 m across, 6 cm ground clearance under the body: chosen to match the
  datasheet's drawings (no exact figure there); the caster is frictionless, as BubbleRob's.
- Laser: the tutorial's scene (``../shared/SEEDS.md``, seed 002): 180 degrees at 5 rays per
  degree (0.2-degree steps: 901 rays with both edges), ``range_max`` 50 m, published every 4th
  step. ``range_min`` 0.1 m is chosen (the housing's radius and some). Mounted on the top plate,
  0.31 m above the ground like a SICK LMS200 on a P3-DX.
- Front range sensor: the front sonar ring's centre sonar, on the front face; reach 4 m (the
  Pioneer 3 operations manual's "from 10 cm to over 4 m"); ``sensorTrigger`` under 0.8 m
  (BubbleRob's 0.75 s at full speed).
- Motor torque 1.0 N m per wheel: 2.3 m/s^2 at 9 kg, under the tyres' grip (about 3 N m each
  with the centre of mass 6 cm behind the axle), and braking at that rate does not tip the
  robot forward (it has no front caster).
- The arena scales BubbleRob's by the robots' size (0.30 m / 0.11 m bounding circle, about
  2.7) and speed (1.2 / 0.4 m/s): 10 m inside, obstacles 0.2 to 0.6 m in radius or half side
  and 0.5 m tall (above the laser's plane), 0.6 m start clearance, clearance cost from 0.9 m.
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

__all__ = ["PIONEER_P3DX", "WHEEL_RADIUS", "TOP_SPEED"]

WHEEL_RADIUS = 0.0975
"""Metres: the datasheet's 195 mm wheels."""
TOP_SPEED = 1.2
"""m/s, the datasheet's top speed."""

PIONEER_P3DX = RobotDescription(
    name="pioneer_p3dx",
    title="Pioneer 3-DX",
    env_id="PioneerP3DX-v0",
    robot_file=ASSETS_DIR / "pioneer_p3dx.xml",
    scene_file=ASSETS_DIR / "pioneer_arena.xml",
    # The body's rear corners are 0.2974 m from base_link (0.2675 m behind, 0.13 m aside);
    # tests/test_assets.py checks it against the compiled geoms.
    radius=0.30,
    max_wheel_speed=round(TOP_SPEED / WHEEL_RADIUS, 2),  # 12.31 rad/s, the motors' ctrlrange
    max_angular_speed=math.radians(300.0),
    # The window: the housing's radius, 4 cm tall about the laser's plane (0.31 m), above the
    # top plate (0.237 m).
    laser=LaserDefaults(
        num_rays=901,
        fov=math.pi,
        range_min=0.1,
        range_max=50.0,
        publish_every=4,
        window=(0.05, 0.02),
    ),
    proximity=ProximityDefaults(range_max=4.0, trigger_distance=0.8),
    arena=ArenaDefaults(
        size=10.0,
        num_obstacles=(4, 10),
        obstacle_size=(0.2, 0.6),
        start_clearance=0.6,
        clearance_distance=0.9,
        obstacle_height=0.5,
    ),
)
