"""Hand-written controllers with SB3's ``predict(obs, state, episode_start, deterministic)``."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.sensors import LaserSpec
from policies.base import ActionMapper, Observation, batch_size, take

__all__ = ["LaserPolicy", "OneByOnePolicy", "RandomPolicy", "ReactivePolicy"]


class OneByOnePolicy:
    """Shared ``predict``: runs ``_act`` per observation, carrying one number of state per env.

    The state starts (and starts over, where ``episode_start`` is true) at ``FRESH_STATE``.
    """

    FRESH_STATE = 0.0
    """A new episode's state (the navigators': no turn away from the goal's bearing yet)."""

    def __init__(self) -> None:
        self._state: NDArray[np.float64] | None = None

    def predict(
        self,
        observation: Observation,
        state: NDArray[np.float64] | None = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], NDArray[np.float64] | None]:
        """SB3's call: action(s) for one observation or a batch, and the policy's state.

        Stateful policies keep their state between calls themselves when ``state`` is None, and
        start over where ``episode_start`` is true.
        """
        n = batch_size(observation)
        count = 1 if n is None else n
        memory = state if state is not None else self._state
        if memory is None or memory.shape[0] != count:
            memory = np.full(count, self.FRESH_STATE)
        memory = memory.copy()
        if episode_start is not None:
            memory[np.asarray(episode_start, dtype=bool).reshape(count)] = self.FRESH_STATE
        actions = np.empty((count, 2), dtype=np.float32)
        for i in range(count):
            single = take(observation, None if n is None else i)
            actions[i], memory[i] = self._act(single, memory[i])
        self._state = memory
        return (actions[0] if n is None else actions), memory

    def reset(self) -> None:
        """Forget the carried state (call between episodes when not passing ``episode_start``)."""
        self._state = None

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        raise NotImplementedError


class _Policy(OneByOnePolicy):
    """A controller that acts through an :class:`ActionMapper` (wheels or twist)."""

    name = "policy"

    def __init__(self, mapper: ActionMapper) -> None:
        super().__init__()
        self.mapper = mapper


class ReactivePolicy(_Policy):
    """The seeds' ``rosBubbleRob2``: drive forward; when the nose sensor triggers, back up turning.

    CoppeliaSim's node drives both wheels at pi rad/s and, for a while after ``sensorTrigger``,
    runs the left wheel backwards at half and the right at a quarter of that speed. Here the same
    shape is scaled to the wheel limit: forward at ``forward`` of it, backing up at ``-back/2``
    (left) and ``-back/4`` (right) for ``back_time`` seconds.
    """

    name = "reactive"

    def __init__(
        self,
        mapper: ActionMapper,
        trigger_distance: float = 0.3,
        forward: float = 0.8,
        back: float = 1.0,
        back_time: float = 1.5,
        dt: float = 0.05,
    ) -> None:
        super().__init__(mapper)
        self.trigger_distance = trigger_distance
        self.forward = forward
        self.back = back
        self.back_steps = max(1, round(back_time / dt))

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        if float(np.asarray(obs["proximity"])[0]) < self.trigger_distance:
            memory = float(self.back_steps)  # (re)start backing up, as the seed's node does
        if memory > 0:
            return self.mapper.from_wheels(-self.back / 2, -self.back / 4), memory - 1
        return self.mapper.from_wheels(self.forward, self.forward), 0.0


class LaserPolicy(_Policy):
    """Follows the most open direction of the laser scan (a "follow the gap" law).

    For candidate headings within +-``max_heading`` it measures how far a corridor as wide as the
    robot (plus ``margin``) stays free, scores each heading by that free length (up to ``horizon``)
    minus a preference for going straight, steers towards the best one and slows down as the free
    length ahead shrinks (from ``slow_down[0] + slow_down[1]`` metres to ``slow_down[0]``). With
    no heading free for ``boxed_in`` metres it turns in place towards the open side.

    The defaults are BubbleRob's (0.11 m, 0.4 m/s, a 360-degree scan); :meth:`for_robot` scales
    them to another robot's size, speed and scan.
    """

    name = "laser"

    def __init__(
        self,
        mapper: ActionMapper,
        laser_spec: LaserSpec,
        half_width: float = 0.11,
        margin: float = 0.06,
        horizon: float = 1.5,
        max_heading: float = math.radians(100),
        turn_gain: float = 3.0,
        straight_preference: float = 0.25,
        boxed_in: float = 0.2,
        slow_down: tuple[float, float] = (0.15, 0.6),
    ) -> None:
        super().__init__(mapper)
        self.laser_spec = laser_spec
        self.half_width = half_width + margin
        self.horizon = horizon
        self.turn_gain = turn_gain
        self.straight_preference = straight_preference
        self.boxed_in = boxed_in
        self.slow_down = slow_down
        self._ray_angles = laser_spec.angles()
        self._headings = np.linspace(-max_heading, max_heading, 41)
        # Per (heading, ray): the ray's angle relative to the heading, its cosine and |sine|
        # (computed once: they were most of a step's time, recomputed from the same angles).
        self._relative = self._ray_angles[None, :] - self._headings[:, None]
        self._cos_relative = np.cos(self._relative)
        self._abs_sin_relative = np.abs(np.sin(self._relative))

    @classmethod
    def for_robot(
        cls, mapper: ActionMapper, laser_spec: LaserSpec, robot_radius: float
    ) -> LaserPolicy:
        """The law scaled to a robot: widths by its radius, look-ahead by its top speed.

        A scan narrower than a full circle limits the headings to 10 degrees inside its edges
        (a corridor at its edge would have rays on one side only). BubbleRob gets the defaults
        exactly (both scales are 1).
        """
        size = robot_radius / 0.11  # BubbleRob's radius
        speed = mapper.linear_limit / 0.4  # and top speed
        max_heading = math.radians(100)
        if not laser_spec.full_circle:
            max_heading = min(max_heading, laser_spec.fov / 2 - math.radians(10))
        return cls(
            mapper,
            laser_spec,
            half_width=robot_radius,
            margin=0.06 * size,
            horizon=1.5 * speed,
            max_heading=max_heading,
            straight_preference=0.25 * speed,
            boxed_in=0.2 * size,
            slow_down=(0.15 * size, 0.6 * speed),
        )

    def free_length(self, ranges: NDArray[np.float32]) -> NDArray[np.float64]:
        """Free corridor length (m) along each candidate heading."""
        r = np.minimum(np.asarray(ranges, dtype=np.float64), self.horizon + 1.0)
        along = r[None, :] * self._cos_relative
        across = r[None, :] * self._abs_sin_relative  # r >= 0: |r sin| = r |sin|, exactly
        blocks = (across < self.half_width) & (along > 0) & (r[None, :] < self.laser_spec.range_max)
        free: NDArray[np.float64] = np.where(blocks, along, self.horizon).min(axis=1)
        return free.clip(max=self.horizon)

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        free = self.free_length(obs["laser"])
        score = free - self.straight_preference * np.abs(self._headings)
        best = int(np.argmax(score))
        heading = float(self._headings[best])
        max_linear = self.mapper.linear_limit
        angular = float(np.clip(self.turn_gain * heading, -3.0, 3.0))
        if free[best] < self.boxed_in:  # boxed in: turn in place towards the side with more room
            side = 1.0 if free[self._headings > 0].max() >= free[self._headings < 0].max() else -1.0
            return self.mapper.from_twist(0.0, 2.0 * side), memory
        ahead = free[len(free) // 2]
        stop, ramp = self.slow_down
        speed = max_linear * float(np.clip((min(ahead, free[best]) - stop) / ramp, 0.15, 1.0))
        speed *= max(0.2, math.cos(heading))
        return self.mapper.from_twist(speed, angular), memory


class RandomPolicy(_Policy):
    """Uniform random actions (seeded), a baseline."""

    name = "random"

    def __init__(self, mapper: ActionMapper, seed: int | None = None) -> None:
        super().__init__(mapper)
        self._rng = np.random.default_rng(seed)

    def _act(self, obs: Observation, memory: float) -> tuple[NDArray[np.float32], float]:
        return self._rng.uniform(-1, 1, size=2).astype(np.float32), memory
