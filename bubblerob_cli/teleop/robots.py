"""``teleop --robots N --robot robot_1``: the keys drive one robot of a world, a policy the rest.

:class:`OneRobotView` shows the teleop loop one robot of a :func:`bubblerob_env.parallel_env`
world as a single env: its observation, reward, ``info`` and episode end. Every step the other
live robots act by ``--policy`` (one instance each, its own state), in the same physics step.
When the driven robot's episode ends the world starts a new one; a robot the policy drives that
terminates stays where it stopped, an obstacle.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_cli.errors import fail

__all__ = ["OneRobotView", "run_world_teleop"]


class OneRobotView(gym.Env[Any, Any]):
    """Robot ``robot`` (``robot_1`` or ``bubblerob_1``) of ``world``; the others by policies.

    ``make_policy(k)``: the policy of robot ``k`` (``policies.load_policy`` with a single env of
    the world's kwargs: its spaces and limits are the robots').

    Raises:
        ValueError: ``robot`` is not one of the world's robots (the message lists them).
    """

    def __init__(self, world: Any, robot: str, make_policy: Callable[[int], Any]) -> None:
        # robot_1 (the node's namespace) or bubblerob_1 (the agent): index 1
        kind, _, index = robot.rpartition("_")
        agents = [a for a in world.possible_agents if a.rpartition("_")[2] == index]
        agent = agents[0] if agents and kind in ("robot", agents[0].rpartition("_")[0]) else None
        if agent is None:
            names = ", ".join(f"robot_{k}" for k in range(world.num_robots))
            raise ValueError(f"--robot {robot}: not a robot of this world ({names})")
        self.world, self.agent = world, agent
        self.dt = float(world.config.control_timestep)
        self.observation_space = world.observation_space(agent)
        self.action_space = world.action_space(agent)
        self._make_policy = make_policy
        self._policies: dict[str, Any] = {}
        self._states: dict[str, Any] = {}
        self._obs: dict[str, Any] = {}

    @property
    def policy_driven(self) -> list[str]:
        """The robots a policy has driven so far."""
        return sorted(self._policies)

    def _drive(self, agent: str) -> Any:
        """The policy's action for ``agent`` (its instance made on first use)."""
        if agent not in self._policies:
            self._policies[agent] = self._make_policy(int(agent.rpartition("_")[2]))
        start = agent not in self._states
        action, self._states[agent] = self._policies[agent].predict(
            self._obs[agent],
            state=self._states.get(agent),
            episode_start=np.array([start]),
            deterministic=True,
        )
        return action

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """A new episode of the world; the driven robot's observation and info."""
        self._obs, infos = self.world.reset(seed=seed, options=options)
        self._states.clear()
        return self._obs[self.agent], infos[self.agent]

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The keys' action for the driven robot, the policy's for the others: one step."""
        if self.agent not in self.world.agents:
            raise RuntimeError(f"{self.agent}'s episode ended: reset() first")
        actions = {a: self._drive(a) for a in self.world.agents if a != self.agent}
        actions[self.agent] = np.asarray(action, dtype=np.float32)
        observations, rewards, terminations, truncations, infos = self.world.step(actions)
        self._obs = observations
        agent = self.agent
        return (
            observations[agent],
            float(rewards[agent]),
            bool(terminations[agent]),
            bool(truncations[agent]),
            infos[agent],
        )

    def close(self) -> None:
        """Close the world."""
        self.world.close()


def run_world_teleop(args: argparse.Namespace) -> int:
    """``teleop --robots N --robot NAME`` locally: one line and exit 2 for bad input."""
    import curses

    import bubblerob_env
    from bubblerob_cli.teleop.sim import run_teleop
    from bubblerob_env.extras import require_extra
    from policies import load_policy

    robots = {"BubbleRob-v0": "bubblerob", "PioneerP3DX-v0": "pioneer_p3dx"}
    if args.record is not None or args.start_pose is not None:
        fail("teleop", "--record and --start-pose drive one robot: leave them out with --robots")
    if args.env not in robots:
        fail("teleop", f"--robots drives BubbleRob-v0 or PioneerP3DX-v0, got --env {args.env}")
    require_extra("multi", "bubblerob teleop --robots")
    kwargs: dict[str, Any] = {**args.env_kwargs, "action_type": "twist"}
    if args.num_obstacles is not None:
        kwargs["num_obstacles"] = tuple(args.num_obstacles)
    steps = kwargs.pop("max_episode_steps", 1000)
    try:
        world = bubblerob_env.parallel_env(
            num_robots=args.robots, robot=robots[args.env], max_episode_steps=steps, **kwargs
        )
        single = gym.make(args.env, **kwargs)  # the policies' spaces and limits
        view = OneRobotView(
            world,
            args.robot or "robot_0",
            lambda k: load_policy(args.policy, env=single, seed=(args.seed or 0) + k),
        )
    except (TypeError, ValueError) as error:
        fail("teleop", str(error))
    if not (sys.stdin.isatty() and sys.stdout.isatty()):
        view.close()
        fail("teleop", "needs a terminal to read keys from (run it in one, not with piped input)")
    try:
        info = curses.wrapper(run_teleop, view, args.seed, args.max_seconds)
    finally:
        view.close()
        single.close()
    print(f"final pose: x={info['x']:.4f} y={info['y']:.4f} yaw={info['yaw']:.4f} ({view.agent})")
    return 0
