"""What the terminal and the ROS teleop share: the keys, the commanded twist, the pacing.

:class:`TeleopState` turns key presses into a twist command, as fractions of the robot's limits;
:class:`Clock` paces a loop to wall-clock time; :func:`status_line` is the first status line both
variants show.
"""

from __future__ import annotations

import curses
import math
import time
from typing import Any

import numpy as np

__all__ = [
    "ANGULAR_STEP",
    "KEYS",
    "LINEAR_STEP",
    "Clock",
    "TeleopState",
    "start_screen",
    "status_line",
]

LINEAR_STEP = 0.1
"""Change of the forward command per key press, as a fraction of ``max_linear_speed``."""
ANGULAR_STEP = 0.1
"""Change of the turn command per key press, as a fraction of ``max_angular_speed``."""

KEYS: dict[int, tuple[float, float] | str] = {
    curses.KEY_UP: (LINEAR_STEP, 0.0),
    ord("w"): (LINEAR_STEP, 0.0),
    curses.KEY_DOWN: (-LINEAR_STEP, 0.0),
    ord("s"): (-LINEAR_STEP, 0.0),
    curses.KEY_LEFT: (0.0, ANGULAR_STEP),
    ord("a"): (0.0, ANGULAR_STEP),
    curses.KEY_RIGHT: (0.0, -ANGULAR_STEP),
    ord("d"): (0.0, -ANGULAR_STEP),
    ord(" "): "stop",
    ord("q"): "quit",
}
"""Each key's effect: a change of ``(linear, angular)``, ``"stop"`` or ``"quit"``."""


class TeleopState:
    """The commanded twist, as fractions of the env's limits, changed key by key."""

    def __init__(self) -> None:
        """Start at rest."""
        self.linear = 0.0
        self.angular = 0.0
        self.quit = False
        self.last_info: dict[str, Any] | None = None  # the latest step's, for Ctrl-C

    def press(self, key: int) -> None:
        """Apply one key (unknown keys are ignored); upper-case letters act as lower-case."""
        if ord("A") <= key <= ord("Z"):
            key = key - ord("A") + ord("a")
        effect = KEYS.get(key)
        if effect == "stop":
            self.linear = self.angular = 0.0
        elif effect == "quit":
            self.quit = True
        elif isinstance(effect, tuple):
            self.linear = float(np.clip(round(self.linear + effect[0], 6), -1.0, 1.0))
            self.angular = float(np.clip(round(self.angular + effect[1], 6), -1.0, 1.0))

    def read_keys(self, screen: Any) -> None:
        """Apply every key waiting on ``screen`` (a non-blocking curses window)."""
        while (key := screen.getch()) != -1:
            self.press(key)

    @property
    def action(self) -> np.ndarray[Any, np.dtype[np.float32]]:
        """The twist action ``[linear, angular]``."""
        return np.array([self.linear, self.angular], dtype=np.float32)


def start_screen(screen: Any) -> None:
    """Set ``screen`` up for teleop: no cursor, keys read without waiting, arrows as keys."""
    curses.curs_set(0)
    screen.nodelay(True)
    screen.keypad(True)


def status_line(state: TeleopState, speed: float, nearest: float, collisions: int) -> str:
    """The first status line: commanded and measured speed, nearest laser reading, collisions."""
    return (
        f"cmd lin {state.linear:+.1f} ang {state.angular:+.1f} | speed {speed:+.2f} m/s "
        f"| nearest {nearest:.2f} m | collisions {collisions}"
    )


def goal_text(distance: float, bearing: float) -> str:
    """A Nav env's goal for a status line: distance (m) and bearing (degrees, + is left)."""
    return f"goal {distance:.2f} m at {math.degrees(bearing):+.0f} deg"


class Clock:
    """Paces a loop to wall-clock time: one tick every ``period`` s, for ``max_seconds`` at most.

    A loop that falls behind does not try to catch up in a burst: it starts afresh from now.
    """

    def __init__(self, period: float, max_seconds: float | None) -> None:
        """Start the clock now."""
        self.period = period
        self.max_seconds = max_seconds
        self.started = self.next_tick = time.monotonic()

    def wait(self) -> bool:
        """Sleep until the next tick; False once more than ``max_seconds`` have passed."""
        self.next_tick += self.period
        delay = self.next_tick - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            self.next_tick = time.monotonic()  # fell behind: do not try to catch up in a burst
        return self.max_seconds is None or time.monotonic() - self.started <= self.max_seconds
