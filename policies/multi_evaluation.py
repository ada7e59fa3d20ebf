"""One policy on every robot of a world (``bubblerob evaluate --robots N``), per robot-episode.

A world episode from seed ``s`` is ``bubblerob_env.parallel_env(N).reset(seed=s)`` run until
every robot has ended; each of its ``N`` robots is one robot-episode. A robot-episode succeeds
when the robot reaches the time limit without touching anything; otherwise it ended on an
obstacle or wall (``info["collided_with"] == "obstacle"``) or on another robot (the other's
name). Rates carry their Wilson 95% interval over the robot-episodes (they are not independent
within a world: read the intervals as a lower bound on the uncertainty).

The policy is loaded for the single env of the same kwargs (``gym.make(env_id, **kwargs)``),
whose spaces every agent of the world has (checked); it drives all robots in one batched
``predict`` a step, each robot its own row, so stateful controllers keep one state per robot.

A Nav env id (``BubbleRobNav-v0``) gives every robot a goal (``parallel_env(task="nav")``; on the
circle, the antipode of its start, in the arena grown to give room to pass, whose size the single
env then gets too): a robot-episode succeeds when its robot reaches its goal untouched, and its
record adds :func:`~policies.navigation_metrics.episode_record`'s fields, from which
:mod:`policies.crowd_metrics` computes Long et al.'s extra time, extra distance and speed.
``circle_jitter`` (m) makes each seed's circle its own (:mod:`bubblerob_env.multi.placement`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_env.extras import require_extra
from policies.crowd_metrics import CrowdMetrics, crowd_metrics
from policies.loading import load_policy
from policies.navigation_metrics import episode_record
from policies.observations import bubblerob_base
from policies.protocol import wilson_interval

__all__ = [
    "SCENARIOS",
    "MultiEvalResult",
    "evaluate_robots",
    "format_multi_table",
    "run_world_episode",
    "world_env",
]

SCENARIOS = ("random", "circle")
"""Start poses of a world: free random poses, or on a circle facing its centre."""


@dataclass(frozen=True)
class MultiEvalResult:
    """``episodes`` world episodes of ``num_robots`` robots driven by one policy."""

    policy: str
    num_robots: int
    scenario: str
    episodes: int
    per_robot: tuple[dict[str, Any], ...]
    """One record per robot-episode, world by world: ``seed``, ``robot``, ``succeeded``,
    ``collided_with`` (``""``, ``"obstacle"`` or the other robot), ``length``, ``return`` and
    ``speed`` (mean forward speed over the maximum)."""

    @property
    def robot_episodes(self) -> int:
        """Robot-episodes: ``episodes * num_robots``."""
        return len(self.per_robot)

    def count(self, outcome: str) -> int:
        """Robot-episodes that ended in ``outcome``: success, obstacle or robot."""
        if outcome == "success":
            return sum(bool(r["succeeded"]) for r in self.per_robot)
        if outcome == "obstacle":
            return sum(r["collided_with"] == "obstacle" for r in self.per_robot)
        if outcome == "robot":
            return sum(r["collided_with"] not in ("", "obstacle") for r in self.per_robot)
        raise ValueError(f"outcome must be success, obstacle or robot, got {outcome!r}")

    def rate(self, outcome: str) -> tuple[float, float, float]:
        """The rate of ``outcome`` and its Wilson 95% interval, as fractions."""
        hits = self.count(outcome)
        low, high = wilson_interval(hits, self.robot_episodes)
        return hits / self.robot_episodes, low, high

    @property
    def mean_speed_fraction(self) -> float:
        """Mean forward speed over all robot-steps, over the maximum."""
        lengths = np.array([r["length"] for r in self.per_robot], dtype=float)
        speeds = np.array([r["speed"] for r in self.per_robot], dtype=float)
        return float(np.dot(speeds, lengths) / lengths.sum())

    @property
    def crowd(self) -> CrowdMetrics | None:
        """The crowd-navigation metrics of a Nav world's robot-episodes (else None)."""
        if not self.per_robot or "shortest" not in self.per_robot[0]:
            return None
        return crowd_metrics(self.per_robot)

    @property
    def mean_length(self) -> float:
        """Mean robot-episode length in steps."""
        return float(np.mean([r["length"] for r in self.per_robot]))


_TASKS = {
    "bubblerob_env.env:BubbleRobEnv": "wander",
    "bubblerob_env.tasks.nav:BubbleRobNavEnv": "nav",
}


def world_env(
    num_robots: int,
    scenario: str,
    env_id: str,
    env_kwargs: dict[str, Any],
    circle_jitter: float = 0.0,
) -> Any:
    """``parallel_env`` of ``num_robots`` robots with the single env ``env_id``'s settings.

    ``env_id`` is a robot's obstacle-avoidance env (``BubbleRob-v0``, ``PioneerP3DX-v0``) or its
    Nav task (``task="nav"``); its registered robot and time limit are used unless
    ``env_kwargs`` sets them.
    """
    require_extra("multi", "evaluate --robots")
    from bubblerob_env.multi import parallel_env

    spec = gym.spec(env_id)
    task = _TASKS.get(str(spec.entry_point))
    if task is None:
        raise ValueError(
            f"--robots runs BubbleRob-v0, PioneerP3DX-v0 and their Nav-v0 tasks, not {env_id!r}"
        )
    if scenario not in SCENARIOS:
        raise ValueError(f"scenario must be one of {list(SCENARIOS)}, got {scenario!r}")
    kwargs = {**spec.kwargs, **env_kwargs}
    kwargs.setdefault("max_episode_steps", spec.max_episode_steps or 1000)
    return parallel_env(
        num_robots, scenario=scenario, task=task, circle_jitter=circle_jitter, **kwargs
    )


def _load_for_world(name: str, world: Any, env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """``name`` loaded for the single env, checked to take the world's per-agent spaces.

    The single env gets the world's arena (grown on a Nav circle).
    """
    single = gym.make(env_id, **{**env_kwargs, "arena_size": world.config.arena_size})
    try:
        agent = world.possible_agents[0]
        for what in ("observation_space", "action_space"):
            mine, theirs = getattr(world, what)(agent), getattr(single, what)
            if mine != theirs:
                raise ValueError(f"the world's {what} {mine} is not the single env's {theirs}")
        return load_policy(name, single), float(bubblerob_base(single).max_linear_speed)
    finally:
        single.close()


def _stacked(observations: dict[str, Any], agents: Sequence[str]) -> Any:
    """The agents' observations as one batch, a row per agent in ``agents``' order."""
    first = observations[agents[0]]
    if isinstance(first, dict):
        return {key: np.stack([observations[a][key] for a in agents]) for key in first}
    return np.stack([observations[a] for a in agents])


def run_world_episode(world: Any, policy: Any, seed: int, max_speed: float) -> list[dict[str, Any]]:
    """One world episode from ``seed``, deterministic actions; a record per robot.

    Every robot keeps its row in the batch the policy sees; an ended robot's last observation
    stays in its row and its action is dropped.
    """
    agents = list(world.possible_agents)
    goals = world.goals  # None for task="wander"
    latest, infos = world.reset(seed=seed)
    records = {
        agent: {"seed": seed, "robot": agent, "succeeded": False, "collided_with": "",
                "length": 0, "return": 0.0, "speed": 0.0}
        for agent in agents
    }  # fmt: skip
    starting = np.ones(len(agents), dtype=bool)
    while world.agents:
        actions, _ = policy.predict(
            _stacked(latest, agents), episode_start=starting, deterministic=True
        )
        starting[:] = False
        live = list(world.agents)
        step = world.step({a: actions[agents.index(a)] for a in live})
        observations, rewards, terminations, truncations, infos = step
        for agent in live:
            record, info = records[agent], infos[agent]
            latest[agent] = observations[agent]
            record["length"] += 1
            record["return"] += float(rewards[agent])
            record["speed"] += float(info["body_twist"][0]) / max_speed
            if terminations[agent] or truncations[agent]:
                record["succeeded"] = bool(info["is_success"])
                record["collided_with"] = str(info.get("collided_with", ""))
                if goals is not None:
                    dt, radius = world.config.control_timestep, goals.settings.goal_radius
                    record.update(
                        episode_record(info, int(record["length"]), dt, max_speed, radius)
                    )
    for record in records.values():
        record["speed"] /= max(record["length"], 1)
    return list(records.values())


def evaluate_robots(
    policy_name: str,
    num_robots: int,
    scenario: str = "random",
    episodes: int = 50,
    seed: int = 100_000,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
    circle_jitter: float = 0.0,
) -> MultiEvalResult:
    """``episodes`` world episodes from seeds ``seed, seed + 1, ...``, one policy on every robot."""
    kwargs = dict(env_kwargs or {})
    world = world_env(num_robots, scenario, env_id, kwargs, circle_jitter)
    try:
        policy, max_speed = _load_for_world(policy_name, world, env_id, kwargs)
        seeds: Any = range(seed, seed + episodes)
        if progress:
            from tqdm import tqdm

            label = f"evaluate {policy_name} x{num_robots} {scenario}"
            seeds = tqdm(seeds, desc=label, unit="world")
        records = [r for s in seeds for r in run_world_episode(world, policy, s, max_speed)]
    finally:
        world.close()
    return MultiEvalResult(str(policy_name), num_robots, scenario, episodes, tuple(records))


def format_multi_table(results: Sequence[MultiEvalResult], markdown: bool = False) -> str:
    """One row per result, per robot-episode: success, obstacle and robot-robot collisions.

    Each rate with its Wilson 95% interval; then speed over the maximum and the mean length.
    """
    header = [
        "policy", "robots", "scenario", "robot-episodes", "success", "obstacle hit",
        "robot hit", "speed/max", "length",
    ]  # fmt: skip

    def cell(result: MultiEvalResult, outcome: str) -> str:
        rate, low, high = result.rate(outcome)
        return f"{rate:.1%} ({low:.1%}-{high:.1%})"

    rows = [
        [
            r.policy, str(r.num_robots), r.scenario, str(r.robot_episodes),
            cell(r, "success"), cell(r, "obstacle"), cell(r, "robot"),
            f"{r.mean_speed_fraction:.1%}", f"{r.mean_length:.0f}",
        ]
        for r in results
    ]  # fmt: skip
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    return "\n".join(
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
        for row in [header, *rows]
    )
