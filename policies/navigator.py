"""Goal-reaching controllers for the Nav task: ``navigator`` (the baseline) and ``pursuit``.

- :class:`NavigatorPolicy` reads only its observation: the goal's distance and bearing, and the
  laser. It steers along the free heading that best trades the gap follower's free corridor
  (:class:`~policies.handwritten.LaserPolicy`) against the angle away from the goal.
- :class:`CrowdNavigatorPolicy` is the navigator among robots like itself: it reads a narrow
  return of the scan (another robot's laser window) as that robot's whole body, and passes
  robots on the right.
- :class:`PursuitPolicy` is the upper reference: it reads the ground truth (the episode's layout
  and the robot's pose, ``env.unwrapped``), plans the shortest path with some room to spare and
  follows it by pure pursuit. It drives the one env it was loaded for.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env.tasks.goals import clearance_grid, plan_path
from bubblerob_env.tasks.nav import BubbleRobNavEnv
from policies.base import ActionMapper, Observation
from policies.handwritten import LaserPolicy, OneByOnePolicy
from policies.observations import PolicyEnvMismatchError, check_observations

__all__ = [
    "NAVIGATION_POLICIES",
    "CrowdNavigatorPolicy",
    "NavigatorPolicy",
    "PursuitPolicy",
    "navigation_policy",
]

NAVIGATION_POLICIES = (
    "navigator",
    "pursuit",
    "crowd_navigator",
    "navigator_observed",
    "crowd_navigator_observed",
)
"""The built-in controllers of ``BubbleRobNav-v0`` / ``PioneerP3DXNav-v0``."""
_HEADINGS = 41  # candidate headings, as LaserPolicy's
_BUBBLEROB_RADIUS, _BUBBLEROB_SPEED = 0.11, 0.4  # what the gains below were tuned for
_OBSERVED_MARGIN = 1.5  # navigator_observed's margin over the navigator's (validation seeds)
_TURNING = 0.1  # *_observed, boxed in: a turn rate above this share of the limit goes on


def navigation_policy(
    name: str, base: Any, space: spaces.Dict | None, mapper: ActionMapper
) -> NavigatorPolicy | PursuitPolicy:
    """The controller ``name`` (:data:`NAVIGATION_POLICIES`) for the Nav env ``base``."""
    if not isinstance(base, BubbleRobNavEnv):
        raise PolicyEnvMismatchError(
            f"policy {name!r} drives to a goal: it needs a Nav env (BubbleRobNav-v0, "
            f"PioneerP3DXNav-v0), got {type(base).__name__}"
        )
    laser = base.laser_spec
    if laser is None:
        raise ValueError(f"the {name} policy needs an env with a laser (laser_num_rays > 0)")
    if space is not None:
        check_observations(name, {"goal": (2,), "laser": (laser.num_rays,)}, space)
    if name == "pursuit":
        return PursuitPolicy(mapper, base)
    max_heading = math.pi if laser.full_circle else laser.fov / 2 - math.radians(10)
    law = _scaled_gap_law(base.robot.radius, mapper, max_heading)
    observed = name.endswith("_observed")
    if observed:
        # A teacher for a network: half as much margin again, room for the imitation's errors.
        law["margin"] *= _OBSERVED_MARGIN
    gap = LaserPolicy(mapper, laser, **law)
    tight = LaserPolicy(mapper, laser, **{**law, "margin": 0.25 * law["margin"]})
    if name.startswith("crowd_navigator"):
        window = base.robot.laser.window[0]
        return CrowdNavigatorPolicy(
            gap, max_heading, base.robot.radius, tight, window=window, observed_memory=observed
        )
    return NavigatorPolicy(gap, max_heading, base.robot.radius, tight, observed_memory=observed)


def _scaled_gap_law(radius: float, mapper: ActionMapper, max_heading: float) -> dict[str, Any]:
    """The gap follower's widths scaled by the robot's radius, its look-ahead by its speed."""
    size, speed = radius / _BUBBLEROB_RADIUS, mapper.linear_limit / _BUBBLEROB_SPEED
    return {
        "half_width": radius,
        "margin": 0.06 * size,
        "horizon": 1.5 * speed,
        "max_heading": max_heading,
        "boxed_in": 0.2 * size,
        "slow_down": (0.15 * size, 0.6 * speed),
    }


class NavigatorPolicy(OneByOnePolicy):
    """Goal seeking with the gap follower's avoidance, from the observation alone.

    Each candidate heading scores its free corridor length (the gap follower's, capped at the
    goal's distance plus a margin: beyond the goal nothing matters) minus ``goal_weight`` metres
    per radian between it and the goal's bearing, minus ``commit_weight`` metres per radian
    between its angle from the goal and the last step's (the memory): once it goes round an
    obstacle on one side it keeps to that side instead of swinging between the two. It steers to
    the best heading, turning in place when that is more than 90 degrees off (or, with a scan
    narrower than a circle, when the goal is behind and it is not going round something), and
    slows as the corridor ahead or the goal's distance shrinks. Within the gap follower's horizon
    of the goal its corridors keep a quarter of the margin (``tight``): a goal may lie in a gap
    that is free for the robot but not for the margin.

    With ``observed_memory`` (``navigator_observed``, which also keeps 1.5 times the margin from
    obstacles: room for a network's errors when it imitates) the memory is not carried but read
    from the observation: the last step's heading is its turn rate over the turn gain (the
    ``velocity`` observation's measured rate), less the goal's bearing now. The controller is
    then a function of the observation alone (its only state: whether the episode has taken a
    step), the teacher a network can imitate: the carried memory follows the navigator's own
    past choices, which on states a network drives into are not the network's (docs/LEARNING.md,
    the ninth round).
    """

    name = "navigator"

    def __init__(
        self,
        gap: LaserPolicy,
        max_heading: float,
        radius: float,
        tight: LaserPolicy | None = None,
        goal_weight: float = 0.5,
        commit_weight: float = 0.3,
        observed_memory: bool = False,
    ) -> None:
        super().__init__()
        self.observed_memory = observed_memory
        if observed_memory:
            self.name = "navigator_observed"
        self.gap = gap
        self.tight = gap if tight is None else tight
        self.mapper = gap.mapper
        self.headings = np.linspace(-max_heading, max_heading, _HEADINGS)
        self.max_heading = max_heading
        self.radius = radius
        self.goal_weight = goal_weight * gap.horizon / 1.5
        self.commit_weight = commit_weight * gap.horizon / 1.5

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        if not self.observed_memory:
            return self._steer(obs, memory)
        # The state only says whether a step was taken (FRESH_STATE: not yet). Before it there is
        # no last heading: the goal's, as the carried memory starts.
        fresh = memory == self.FRESH_STATE
        action, _ = self._steer(obs, self.FRESH_STATE if fresh else self.memory_in(obs))
        return action, self.FRESH_STATE + 1.0

    def _boxed_in_side(self, obs: Observation, free: NDArray[np.float64]) -> float:
        """+1 (left) or -1 (right): the side with more room to turn to when boxed in.

        With ``observed_memory``, the side it is already turning to while it turns (the
        observation's measured rate): the side with more room flips as the robot turns, and a
        network that averages both labels stands still.
        """
        if self.observed_memory:
            turning = float(obs["velocity"][1])
            if abs(turning) > _TURNING * self.mapper.angular_limit:
                return math.copysign(1.0, turning)
        return 1.0 if free[self.headings > 0].max() >= free[self.headings < 0].max() else -1.0

    def memory_in(self, obs: Observation) -> float:
        """The last step's heading from the goal, as the observation shows it (see the class)."""
        turn_rate, bearing = float(obs["velocity"][1]), float(obs["goal"][1])
        off_goal = turn_rate / self.gap.turn_gain - bearing
        return float(np.remainder(off_goal + math.pi, math.tau) - math.pi)

    def _steer(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        distance, bearing = (float(v) for v in np.asarray(obs["goal"]))
        # Close to the goal, a corridor with less margin: goals may lie in tight spots.
        near = distance < self.gap.horizon
        free = (self.tight if near else self.gap).free_length(obs["laser"])
        turn = 0.6 * self.mapper.angular_limit
        outside = abs(bearing) > self.max_heading + math.radians(5)  # behind a narrow scan
        detouring = math.isfinite(memory) and abs(memory) > math.pi / 3
        if outside and not detouring:  # turn to face it (going round something: carry on)
            return self.mapper.from_twist(0.0, math.copysign(turn, bearing)), memory
        reach = np.minimum(free, distance + 2.0 * self.radius)
        off_goal = np.remainder(self.headings - bearing + math.pi, math.tau) - math.pi
        score = reach - self.goal_weight * np.abs(off_goal)
        if math.isfinite(memory):
            score -= self.commit_weight * np.abs(off_goal - memory)
        best = int(np.argmax(score))
        heading = float(self.headings[best])
        if free[best] < min(self.gap.boxed_in, distance):  # boxed in: turn towards more room
            return self.mapper.from_twist(0.0, self._boxed_in_side(obs, free) * turn), memory
        limit = self.mapper.angular_limit
        angular = float(np.clip(self.gap.turn_gain * heading, -limit, limit))
        if abs(heading) > math.pi / 2:
            return self.mapper.from_twist(0.0, angular), float(off_goal[best])
        stop, ramp = self.gap.slow_down
        ahead = min(free[len(free) // 2], free[best])
        fraction = float(np.clip((ahead - stop) / ramp, 0.15, 1.0))
        fraction = min(fraction, max(0.3, distance / (4.0 * self.radius)))
        speed = self.mapper.linear_limit * fraction * max(0.0, math.cos(heading))
        return self.mapper.from_twist(speed, angular), float(off_goal[best])


class CrowdNavigatorPolicy(NavigatorPolicy):
    """The navigator among other robots: a narrow return is a robot's body, passed on the right.

    Another robot shows in the scan only as its laser window (a few centimetres wide). A run of
    rays whose neighbours on both sides, a robot's width away (``body``), lie ``drop`` m farther
    is read as a window within ``reach`` m: the scan is cut down to the disc of radius ``body``
    (the robot's radius and a margin) behind it, as if the whole robot were seen. While such a
    robot is within ``yield_distance`` m and 57 degrees of the heading, the goal's bearing is
    turned ``keep_right`` rad to the right: every robot keeps right, so a crossing turns into a
    roundabout instead of a meeting in the middle. Chosen on validation seeds (1000-1004, circle
    crossings of 4 to 20 robots).

    With ``observed_memory`` (``crowd_navigator_observed``, 1.5 times the margin, as
    ``navigator_observed``): its side memory read from the observation, the teacher of the crowd
    recipe (docs/LEARNING.md, the tenth round).
    """

    name = "crowd_navigator"

    def __init__(
        self,
        gap: LaserPolicy,
        max_heading: float,
        radius: float,
        tight: LaserPolicy | None = None,
        window: float = 0.025,
        keep_right: float = 0.6,
        observed_memory: bool = False,
    ) -> None:
        super().__init__(gap, max_heading, radius, tight, observed_memory=observed_memory)
        self.name = "crowd_navigator_observed" if observed_memory else "crowd_navigator"
        angles = gap.laser_spec.angles()
        self.rays = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        self.ahead = np.abs(angles) < 1.0
        self.step = float(gap.laser_spec.angle_increment)
        self.window, self.keep_right = window, keep_right
        self.body, self.width = radius + 0.09 * radius / _BUBBLEROB_RADIUS, 0.07 * radius / 0.11
        self.drop, self.reach, self.yield_distance = 0.2, 2.5, 1.5

    def seen_robots(self, ranges: NDArray[np.float32]) -> NDArray[np.bool_]:
        """The rays that end on a narrow return: another robot's window."""
        r = np.asarray(ranges, dtype=np.float64)
        n = r.size
        reach_out = np.arcsin(np.minimum(1.0, self.width / np.maximum(r, self.width)))
        k = np.ceil(reach_out / self.step).astype(np.int64) + 1
        i = np.arange(n)
        side = (r[(i - k) % n] > r + self.drop) & (r[(i + k) % n] > r + self.drop)
        narrow: NDArray[np.bool_] = (r < self.reach) & side
        return narrow

    def with_bodies(self, ranges: NDArray[np.float32], narrow: NDArray[np.bool_]) -> Any:
        """The scan cut down to a disc of radius ``body`` behind every narrow return."""
        r = np.asarray(ranges, dtype=np.float64)
        centres = (r[narrow] + self.window)[:, None] * self.rays[narrow]
        along = self.rays @ centres.T
        inside = self.body**2 - ((centres**2).sum(axis=1)[None, :] - along**2)
        hit = (inside >= 0) & (along > 0)
        entry = np.where(hit, along - np.sqrt(np.maximum(inside, 0.0)), np.inf).min(axis=1)
        return np.minimum(r, np.maximum(entry, 0.01)).astype(np.float32)

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        laser = np.asarray(obs["laser"])
        narrow = self.seen_robots(laser)
        if not narrow.any():
            return super()._act(obs, memory)
        goal = np.array(obs["goal"], dtype=np.float32)
        if (narrow & self.ahead & (laser < self.yield_distance)).any():
            goal[1] -= self.keep_right
        seen = {**obs, "laser": self.with_bodies(laser, narrow), "goal": goal}
        return super()._act(seen, memory)


class PursuitPolicy(OneByOnePolicy):
    """Pure pursuit on the ground-truth shortest path: an upper reference, not a baseline.

    At each new episode of its env it plans the shortest path from the robot to the goal on the
    ground-truth grid widened by ``clearance`` robot radii (less if that closes every way, down
    to one radius: the env's own grid), then steers at the path point ``lookahead`` radii ahead
    with pure pursuit's curvature ``2 sin(alpha) / L``, turning in place when that point is more
    than 60 degrees off the heading.
    """

    name = "pursuit"

    def __init__(
        self,
        mapper: ActionMapper,
        env: BubbleRobNavEnv,
        clearance: tuple[float, ...] = (1.8, 1.5, 1.25, 1.0),
        lookahead: float = 1.5,
    ) -> None:
        super().__init__()
        self.mapper = mapper
        self.env = env
        self.clearance = clearance
        self.lookahead = lookahead * env.robot.radius
        self.path: NDArray[np.float64] = np.zeros((0, 2))
        """The path being followed, resampled every tenth of a radius."""
        self._planned_for: object = None
        self._progress = 0

    def _plan(self) -> None:
        env = self.env
        assert env.layout is not None and env.problem is not None
        start, goal = env.robot_pose[:2], env.problem.goal
        radius = env.robot.radius
        path = env.problem.path
        for factor in self.clearance:
            grid = clearance_grid(env.layout, float(env.arena_size), factor * radius)
            planned = plan_path(grid, (start[0], start[1]), goal)
            if planned is not None:
                path = planned
                break
        self.path = _resampled(path, 0.1 * radius)
        self._planned_for = env.problem
        self._progress = 0

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        env = self.env
        if env.problem is not self._planned_for:
            self._plan()
        x, y, yaw = env.robot_pose
        gaps = np.hypot(self.path[:, 0] - x, self.path[:, 1] - y)
        window = slice(self._progress, self._progress + max(1, round(len(self.path) / 4)) + 20)
        self._progress += int(np.argmin(gaps[window]))
        beyond = np.flatnonzero(gaps[self._progress :] >= self.lookahead)
        target = self.path[self._progress + beyond[0]] if beyond.size else self.path[-1]
        alpha = math.remainder(math.atan2(target[1] - y, target[0] - x) - yaw, math.tau)
        if abs(alpha) > math.radians(60):
            turn = math.copysign(0.6 * self.mapper.angular_limit, alpha)
            return self.mapper.from_twist(0.0, turn), memory
        distance = max(float(np.hypot(target[0] - x, target[1] - y)), 1e-6)
        speed = self.mapper.linear_limit * max(0.3, math.cos(alpha))
        return self.mapper.from_twist(speed, 2.0 * speed * math.sin(alpha) / distance), memory


def _resampled(path: NDArray[np.float64], spacing: float) -> NDArray[np.float64]:
    """``path``'s polyline as points every ``spacing`` metres (its corners kept)."""
    points = [path[:1]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        steps = max(1, math.ceil(float(np.hypot(*(b - a))) / spacing))
        t = np.linspace(0.0, 1.0, steps + 1)[1:, None]
        points.append(a + t * (b - a))
    return np.vstack(points)
