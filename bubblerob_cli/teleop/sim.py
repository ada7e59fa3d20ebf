"""``bubblerob teleop``'s local drive: the keys step a simulated env (twist actions) at real time.

A status line shows the commanded and measured speed, the nearest laser reading and the
collisions so far, the next the pose (and a Nav env's goal: distance and bearing); the env runs
at its own control rate (20 Hz by default), paced to wall-clock time. An episode that ends
starts the next one at rest.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_cli.teleop.keys import Clock, TeleopState, goal_text, start_screen, status_line

__all__ = ["run_teleop"]


def run_teleop(
    screen: Any,
    env: gym.Env[Any, Any],
    seed: int | None,
    max_seconds: float | None = None,
) -> dict[str, Any]:
    """Drive ``env`` (twist actions) from ``screen``'s keys until q; return the last info."""
    start_screen(screen)
    state = TeleopState()
    _, info = env.reset(seed=seed)
    dt = float(env.unwrapped.dt)  # type: ignore[attr-defined]
    try:
        info = _drive(screen, env, state, info, dt, max_seconds)
    except KeyboardInterrupt:  # Ctrl-C quits as q does: no traceback, the last pose printed
        info = state.last_info or info
    return info


def _drive(
    screen: Any,
    env: gym.Env[Any, Any],
    state: TeleopState,
    info: dict[str, Any],
    dt: float,
    max_seconds: float | None,
) -> dict[str, Any]:
    """The teleop loop: keys, a step, the status lines, at real time; the last info."""
    collisions = 0
    clock = Clock(dt, max_seconds)
    episode = 0
    while not state.quit:
        state.read_keys(screen)
        if state.quit:
            break
        obs, _, terminated, truncated, info = env.step(state.action)
        state.last_info = info
        collisions += bool(info["collision"])
        nearest = float(np.min(obs["laser"])) if "laser" in obs else float("nan")
        screen.erase()
        screen.addstr(0, 0, "BubbleRob teleop: arrows/WASD drive, space stops, q quits")
        width = max(screen.getmaxyx()[1] - 1, 1)
        forward = float(info["body_twist"][0])
        screen.addstr(1, 0, status_line(state, forward, nearest, collisions)[:width])
        pose = f"pose x={info['x']:+.2f} y={info['y']:+.2f} yaw={info['yaw']:+.2f}"
        if "goal" in obs:  # a Nav env: the goal as the robot sees it
            pose += " | " + goal_text(*(float(v) for v in obs["goal"]))
            pose += " (reached)" if info.get("is_success") else ""
        screen.addstr(2, 0, f"{pose} | episode {episode} | sim {info['sim_time']:.1f} s"[:width])
        screen.refresh()
        if terminated or truncated:
            episode += 1
            state.linear = state.angular = 0.0
            obs, info = env.reset()
            state.last_info = info
        if not clock.wait():
            break
    return info
