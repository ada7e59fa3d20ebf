"""Warp kernels of the device batch: everything of a step that is not MuJoCo Warp's physics.

Each kernel does on the device, for every world at once, what the CPU kernel
(:mod:`bubblerob_env.core.kernel`) does for one robot: the wheel commands from the actions, the
collision check after each substep, the laser's rays from the laser site and their readings, the
proximity and velocity readings, the reward and its parts, the odometry, the time limit, and the
episode flags. Results go into the same :class:`~bubblerob_env.core.kernel.OUT` columns as the CPU
kernel's, in float32 (MuJoCo Warp's precision). Resets write a layout table's rows (see
:mod:`bubblerob_env.mjwarp.layouts`) into the worlds being reset.
"""

from __future__ import annotations

from typing import Any

import warp as wp

from bubblerob_env.core.kernel import OUT

__all__ = [
    "Settings",
    "apply_command",
    "check_actions",
    "flag_collisions",
    "flatten_observations",
    "laser_readings",
    "place_geoms",
    "place_mocaps",
    "place_robots",
    "sense",
    "world_rays",
]

# The result columns, as Warp constants.
_REWARD = wp.constant(int(OUT.REWARD))
_FORWARD = wp.constant(int(OUT.FORWARD))
_SPIN = wp.constant(int(OUT.SPIN))
_CLEARANCE = wp.constant(int(OUT.CLEARANCE))
_COLLISION_COST = wp.constant(int(OUT.COLLISION_COST))
_COLLISION = wp.constant(int(OUT.COLLISION))
_DIVERGED = wp.constant(int(OUT.DIVERGED))
_CLIPPED = wp.constant(int(OUT.CLIPPED))
_SIM_TIME = wp.constant(int(OUT.SIM_TIME))
_POSITION = wp.constant(int(OUT.POSITION))
_QUATERNION = wp.constant(int(OUT.QUATERNION))
_YAW = wp.constant(int(OUT.YAW))
_TWIST = wp.constant(int(OUT.TWIST))
_WHEEL_SPEEDS = wp.constant(int(OUT.WHEEL_SPEEDS))
_WHEEL_COMMAND = wp.constant(int(OUT.WHEEL_COMMAND))

# Columns of the per-world integer state.
STEPS, COLLIDED, CLIPPED_COUNT, TERMINATED, TRUNCATED, NOISE_DRAWS = range(6)
STATE_SIZE = 6
_STEPS = wp.constant(STEPS)
_COLLIDED = wp.constant(COLLIDED)
_CLIPPED_COUNT = wp.constant(CLIPPED_COUNT)
_TERMINATED = wp.constant(TERMINATED)
_TRUNCATED = wp.constant(TRUNCATED)
_NOISE_DRAWS = wp.constant(NOISE_DRAWS)


@wp.struct
class Settings:
    """What every world of a batch shares: the env's kwargs and the model's addresses."""

    twist: int
    max_wheel: float
    max_linear: float
    max_angular: float
    wheel_radius: float
    wheel_separation: float
    has_laser: int
    range_max: float
    noisy_ceiling: float
    laser_noise: float
    proximity_max: float
    limit_linear: float
    limit_angular: float
    forward_weight: float
    spin_weight: float
    clearance_weight: float
    clearance_distance: float
    hull: float
    collision_penalty: float
    terminate_on_collision: int
    max_episode_steps: int  # 0: no time limit
    odometry_noise: float
    velocity_adr: int
    gyro_adr: int
    left_wheel_adr: int
    right_wheel_adr: int
    proximity_adr: int
    root_qpos: int
    laser_site: int


@wp.kernel
def check_actions(actions: wp.array2d[float], bad: wp.array[int]) -> None:
    """``bad[0]`` = 1 + the lowest world whose action is NaN or infinite (0: none)."""
    w = wp.tid()
    if not (wp.isfinite(actions[w, 0]) and wp.isfinite(actions[w, 1])):
        wp.atomic_min(bad, 1, w)
        bad[0] = 1


@wp.kernel
def apply_command(
    actions: wp.array2d[float],
    s: Settings,
    ctrl: wp.array2d[float],
    out: wp.array2d[float],
) -> None:
    """Clip each action to [-1, 1] and scale it into wheel speed targets (the CPU kernel's)."""
    w = wp.tid()
    a0, a1 = actions[w, 0], actions[w, 1]
    c0, c1 = wp.clamp(a0, -1.0, 1.0), wp.clamp(a1, -1.0, 1.0)
    out[w, _CLIPPED] = wp.where(c0 != a0 or c1 != a1, 1.0, 0.0)
    left, right = c0 * s.max_wheel, c1 * s.max_wheel
    if s.twist != 0:
        linear, angular = c0 * s.max_linear, c1 * s.max_angular
        half_track = s.wheel_separation / 2.0
        left = (linear - angular * half_track) / s.wheel_radius
        right = (linear + angular * half_track) / s.wheel_radius
        peak = wp.max(wp.abs(left), wp.abs(right))
        if peak > s.max_wheel:
            scale = s.max_wheel / peak
            left, right = left * scale, right * scale
    out[w, _WHEEL_COMMAND] = left
    out[w, _WHEEL_COMMAND + 1] = right
    ctrl[w, 0] = left
    ctrl[w, 1] = right


@wp.kernel
def flag_collisions(
    nacon: wp.array[int],
    contact_geom: wp.array[wp.vec2i],
    contact_world: wp.array[int],
    is_obstacle: wp.array[int],
    collision: wp.array[int],
) -> None:
    """Mark the worlds with a contact that involves a wall or obstacle geom."""
    c = wp.tid()
    if c >= nacon[0]:
        return
    g = contact_geom[c]
    hit = False
    if g[0] >= 0:
        hit = is_obstacle[g[0]] != 0
    if g[1] >= 0 and is_obstacle[g[1]] != 0:
        hit = True
    if hit:
        collision[contact_world[c]] = 1


@wp.kernel
def world_rays(
    site_xpos: wp.array2d[wp.vec3],
    site_xmat: wp.array2d[wp.mat33],
    site: int,
    local_dirs: wp.array[wp.vec3],
    pnt: wp.array2d[wp.vec3],
    vec: wp.array2d[wp.vec3],
) -> None:
    """Each ray's origin (the laser site) and direction in the world frame."""
    w, r = wp.tid()
    pnt[w, r] = site_xpos[w, site]
    vec[w, r] = site_xmat[w, site] @ local_dirs[r]


@wp.kernel
def laser_readings(
    dist: wp.array2d[float],
    s: Settings,
    seeds: wp.array[int],
    state: wp.array2d[int],
    active: wp.array[int],
    laser: wp.array2d[float],
    nearest: wp.array[float],
) -> None:
    """No hit reads ``range_max``; noise on hits; ``nearest`` is each world's lowest reading."""
    w, r = wp.tid()
    if active[w] == 0:
        return
    d = dist[w, r]
    hit = d >= 0.0 and d < s.range_max
    reading = wp.where(hit, d, s.range_max)
    if s.laser_noise > 0.0 and hit:
        rng = wp.rand_init(seeds[w], state[w, _NOISE_DRAWS] * dist.shape[1] + r)
        reading = wp.clamp(reading + s.laser_noise * wp.randn(rng), 0.0, s.noisy_ceiling)
    laser[w, r] = reading
    wp.atomic_min(nearest, w, reading)


@wp.func
def _wrap(angle: float) -> float:
    return wp.atan2(wp.sin(angle), wp.cos(angle))


@wp.func
def _advance_odometry(
    w: int, x: float, y: float, yaw: float, slip0: float, slip1: float, s: Settings, odom: Any
) -> None:
    """One step of dead reckoning from the true motion (``odometry.integrate_travel``)."""
    dx, dy = x - odom[w, 3], y - odom[w, 4]
    forward = wp.cos(odom[w, 5]) * dx + wp.sin(odom[w, 5]) * dy
    chord = wp.sqrt(dx * dx + dy * dy)
    if forward < 0.0:
        chord = -chord
    turn = _wrap(yaw - odom[w, 5])
    left = (chord - 0.5 * turn * s.wheel_separation) * (1.0 + slip0)
    right = (chord + 0.5 * turn * s.wheel_separation) * (1.0 + slip1)
    distance = 0.5 * (left + right)
    odom_turn = (right - left) / s.wheel_separation
    heading = odom[w, 2] + 0.5 * odom_turn
    odom[w, 0] = odom[w, 0] + distance * wp.cos(heading)
    odom[w, 1] = odom[w, 1] + distance * wp.sin(heading)
    odom[w, 2] = _wrap(odom[w, 2] + odom_turn)
    odom[w, 3] = x
    odom[w, 4] = y
    odom[w, 5] = yaw


@wp.func
def _diverged(qpos: Any, qvel: Any, w: int) -> bool:
    """MuJoCo Warp raises no warnings: a state that is not finite has diverged."""
    for j in range(qpos.shape[1]):
        if not wp.isfinite(qpos[w, j]):
            return True
    for j in range(qvel.shape[1]):  # noqa: SIM110 (a Warp function: no generators)
        if not wp.isfinite(qvel[w, j]):
            return True
    return False


@wp.func
def _observe(
    w: int, sd: Any, qpos: Any, time: Any, s: Settings, prox: Any, vel: Any, out: Any
) -> None:
    """Proximity, velocity and the pose, twist and wheel numbers of ``info``."""
    reach = sd[w, s.proximity_adr]
    if reach < 0.0 or reach > s.proximity_max:
        reach = s.proximity_max
    prox[w, 0] = reach
    vel[w, 0] = wp.clamp(sd[w, s.velocity_adr], -s.limit_linear, s.limit_linear)
    vel[w, 1] = wp.clamp(sd[w, s.gyro_adr + 2], -s.limit_angular, s.limit_angular)
    for j in range(3):
        out[w, _TWIST + j] = sd[w, s.velocity_adr + j]
        out[w, _TWIST + 3 + j] = sd[w, s.gyro_adr + j]
    out[w, _WHEEL_SPEEDS] = sd[w, s.left_wheel_adr]
    out[w, _WHEEL_SPEEDS + 1] = sd[w, s.right_wheel_adr]
    for j in range(7):
        out[w, _POSITION + j] = qpos[w, s.root_qpos + j]
    qw, qx, qy, qz = (
        out[w, _QUATERNION],
        out[w, _QUATERNION + 1],
        out[w, _QUATERNION + 2],
        out[w, _QUATERNION + 3],
    )
    out[w, _YAW] = wp.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    out[w, _SIM_TIME] = time[w]


@wp.func
def _reward(w: int, nearest: float, collided: bool, s: Settings, vel: Any, out: Any) -> None:
    """The reward parts and their sum, as the CPU kernel adds them."""
    forward = s.forward_weight * vel[w, 0] / s.max_linear
    spin = -s.spin_weight * wp.abs(vel[w, 1]) / s.max_angular
    closeness = wp.clamp(
        (s.clearance_distance - nearest) / (s.clearance_distance - s.hull), 0.0, 1.0
    )
    clearance = -s.clearance_weight * closeness
    collision = wp.where(collided, -s.collision_penalty, 0.0)
    out[w, _FORWARD] = forward
    out[w, _SPIN] = spin
    out[w, _CLEARANCE] = clearance
    out[w, _COLLISION_COST] = collision
    out[w, _REWARD] = 0.0 + forward + spin + clearance + collision


@wp.kernel
def sense(
    sensordata: wp.array2d[float],
    qpos: wp.array2d[float],
    qvel: wp.array2d[float],
    time: wp.array[float],
    s: Settings,
    collision: wp.array[int],
    nearest: wp.array[float],
    seeds: wp.array[int],
    active: wp.array[int],
    resetting: wp.array[int],
    state: wp.array2d[int],
    odom: wp.array2d[float],
    prox: wp.array2d[float],
    vel: wp.array2d[float],
    out: wp.array2d[float],
) -> None:
    """Readings, ``info`` numbers, reward, odometry and episode flags of every world.

    Only ``active`` worlds. A world being reset gets its reset values: no reward, no
    collision, no command, its odometry at the true pose, its counters at zero. Each pass
    moves the world's noise stream on (laser noise and wheel slip draw from it).
    """
    w = wp.tid()
    if active[w] == 0:
        return
    draws = state[w, _NOISE_DRAWS]
    state[w, _NOISE_DRAWS] = draws + 1
    _observe(w, sensordata, qpos, time, s, prox, vel, out)
    x, y, yaw = out[w, _POSITION], out[w, _POSITION + 1], out[w, _YAW]
    if resetting[w] != 0:
        for j in range(_REWARD, _COLLISION_COST + 1):
            out[w, j] = 0.0
        out[w, _COLLISION] = 0.0
        out[w, _CLIPPED] = 0.0
        out[w, _DIVERGED] = 0.0
        out[w, _WHEEL_COMMAND] = 0.0
        out[w, _WHEEL_COMMAND + 1] = 0.0
        for j in range(2):
            odom[w, 3 * j] = x
            odom[w, 3 * j + 1] = y
            odom[w, 3 * j + 2] = yaw
        for j in range(_NOISE_DRAWS):
            state[w, j] = 0
        return
    collided = collision[w] != 0
    reading = wp.where(s.has_laser != 0, nearest[w], prox[w, 0])
    _reward(w, reading, collided, s, vel, out)
    out[w, _COLLISION] = wp.where(collided, 1.0, 0.0)
    slip0, slip1 = 0.0, 0.0
    if s.odometry_noise > 0.0:
        rng = wp.rand_init(seeds[w] ^ 0x5F3759DF, draws)
        slip0 = s.odometry_noise * wp.randn(rng)
        slip1 = s.odometry_noise * wp.randn(rng)
    _advance_odometry(w, x, y, yaw, slip0, slip1, s, odom)
    if collided:
        state[w, _COLLIDED] = 1
    if out[w, _CLIPPED] != 0.0:
        state[w, _CLIPPED_COUNT] = state[w, _CLIPPED_COUNT] + 1
    state[w, _STEPS] = state[w, _STEPS] + 1
    diverged = _diverged(qpos, qvel, w)
    out[w, _DIVERGED] = wp.where(diverged, 1.0, 0.0)
    state[w, _TERMINATED] = wp.where(collided and s.terminate_on_collision != 0, 1, 0)
    limit = s.max_episode_steps > 0 and state[w, _STEPS] >= s.max_episode_steps
    state[w, _TRUNCATED] = wp.where(diverged or limit, 1, 0)


@wp.kernel
def place_mocaps(
    resetting: wp.array[int],
    rows: wp.array[int],
    table_pos: wp.array2d[wp.vec3],
    table_quat: wp.array2d[wp.quat],
    mocap_pos: wp.array2d[wp.vec3],
    mocap_quat: wp.array2d[wp.quat],
) -> None:
    """Obstacle poses (and parked slots) of each resetting world's layout row."""
    w, k = wp.tid()
    if resetting[w] == 0:
        return
    row = rows[w]
    mocap_pos[w, k] = table_pos[row, k]
    mocap_quat[w, k] = table_quat[row, k]


@wp.kernel
def place_geoms(
    resetting: wp.array[int],
    rows: wp.array[int],
    slot_geoms: wp.array[int],
    table_size: wp.array2d[wp.vec3],
    table_rbound: wp.array2d[float],
    geom_size: wp.array2d[wp.vec3],
    geom_rbound: wp.array2d[float],
    geom_aabb: wp.array3d[wp.vec3],
) -> None:
    """Obstacle sizes, bounding spheres and boxes of each resetting world's layout row.

    The geom sits at its body's origin: its box is centred there, its half sides those of the
    obstacle (a cylinder's: radius, radius, half height), as ``ObstacleSlots.apply`` writes them.
    """
    w, k = wp.tid()
    if resetting[w] == 0:
        return
    row, geom = rows[w], slot_geoms[k]
    size = table_size[row, k]
    geom_size[w, geom] = size
    geom_rbound[w, geom] = table_rbound[row, k]
    half = size
    if size[2] == 0.0:  # a cylinder: (radius, half height, 0)
        half = wp.vec3(size[0], size[0], size[1])
    geom_aabb[w, geom, 0] = wp.vec3(0.0)
    geom_aabb[w, geom, 1] = half


@wp.kernel
def place_robots(
    resetting: wp.array[int],
    rows: wp.array[int],
    table_root: wp.array2d[float],
    s: Settings,
    qpos: wp.array2d[float],
) -> None:
    """Each resetting world's robot at its layout's start pose (the free joint's 7 numbers)."""
    w = wp.tid()
    if resetting[w] == 0:
        return
    for j in range(7):
        qpos[w, s.root_qpos + j] = table_root[rows[w], j]


@wp.kernel
def flatten_observations(
    laser: wp.array2d[float],
    nray: int,
    prox: wp.array2d[float],
    vel: wp.array2d[float],
    flat: wp.array2d[float],
) -> None:
    """``obs_mode="flat"``: laser, proximity, velocity side by side, as the CPU env's layout."""
    w = wp.tid()
    for r in range(nray):
        flat[w, r] = laser[w, r]
    flat[w, nray] = prox[w, 0]
    flat[w, nray + 1] = vel[w, 0]
    flat[w, nray + 2] = vel[w, 1]
