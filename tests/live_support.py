"""What the live ROS 1 (tests/live) and ROS 2 (tests/live2) tests share, on the pytest side.

Imported as a plain module (tests/ is on sys.path through tests/conftest.py).
``live_helpers`` and ``ros2_helpers`` add what differs: the ROS 1 master and Debian's tools, the
ROS 2 venv and its DDS domain. The clients they run share ``live_client_support``.
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

LOCALIZE_NODE_ARGS = (
    "--localize", "--rate-factor", "5", "--watchdog", "0", "--seed", "3", "--max-steps", "4000",
    "--env-kwargs", '{"odometry_noise": 0.15, "num_obstacles": [0, 0], "start_pose": [0, -1.4, 0]}',
)  # fmt: skip
"""The localize tests' node: a circle of 1.4 m radius around the empty arena's centre. Raw
odometry drifts 0.4-0.9 m within 15-25 s of it (measured offline over start delays; the tests
drive 17 s), and no wall or episode end interrupts it."""

INITIALPOSE_REJECTIONS = ("undecodable", "non-finite", "initial poses must be in 'map'")
"""What the node reports for the clients' three malformed ``/initialpose`` messages."""


def stop(proc: subprocess.Popen[Any], sig: int = signal.SIGINT, timeout: float = 10.0) -> None:
    """Stop a process we started: ``sig``, then SIGKILL after ``timeout``."""
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def wait_for(predicate: Callable[[], object], timeout: float, interval: float = 0.05) -> bool:
    """Whether ``predicate()`` became true within ``timeout`` seconds (polled)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(interval)
    return bool(predicate())


def run_json_client(
    command: Sequence[str], env: Mapping[str, str], timeout: float, cwd: Path | None = None
) -> Any:
    """Run a client script's subcommand to completion; the JSON of its last stdout line."""
    result = subprocess.run(
        list(command), env=dict(env), cwd=cwd, capture_output=True, text=True, timeout=timeout,
        check=False,
    )  # fmt: skip
    assert result.returncode == 0, f"client {command[2:]} failed:\n{result.stdout}\n{result.stderr}"
    return json.loads(result.stdout.strip().splitlines()[-1])


class NodeProcess:
    """A ``bubblerob node`` subprocess, started until it prints ``ready``; output collected."""

    def __init__(
        self,
        command: Sequence[str],
        env: Mapping[str, str],
        args: list[str],
        ready_timeout: float,
        cwd: Path | None = None,
    ) -> None:
        self.args = args
        self.proc = subprocess.Popen(
            [*command, *args],
            env=dict(env),
            cwd=cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.out: list[str] = []
        self.err: list[str] = []
        self._ready = threading.Event()
        self._said_ready = False
        readers = [
            threading.Thread(target=self._read, args=(stream, into), daemon=True)
            for stream, into in ((self.proc.stdout, self.out), (self.proc.stderr, self.err))
        ]
        for reader in readers:
            reader.start()
        self._ready.wait(ready_timeout)
        if not self._said_ready or self.proc.poll() is not None:
            self.stop()
            for reader in readers:
                reader.join(5.0)
            raise AssertionError(f"node {args} did not start:\n{self.output}")

    def _read(self, stream: Any, into: list[str]) -> None:
        for line in stream:
            into.append(line)
            if "ready" in line:
                self._said_ready = True
                self._ready.set()
        # End of output: the node exited. Stop waiting for it at once, not after ready_timeout.
        self._ready.set()

    @property
    def output(self) -> str:
        return "".join(self.out) + "".join(self.err)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self) -> int:
        stop(self.proc, signal.SIGTERM)
        return int(self.proc.returncode)


def odometry_drift(got: dict[str, Any]) -> float:
    """How far the last ``/odom`` pose of a ``localize`` client run is from the truth (m)."""
    truth = {int(t[0]): t[1:] for t in got["truth"]}
    stamp, *odom = got["odom_last"]
    true = truth[int(stamp)]
    return math.hypot(odom[0] - true[0], odom[1] - true[1])


def tracking_errors(got: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Position and yaw errors of each ``/amcl_pose`` against the truth at its stamp."""
    truth = {int(t[0]): t[1:] for t in got["truth"]}
    pairs = [(p[1:], truth[int(p[0])]) for p in got["tracked"] if int(p[0]) in truth]
    assert len(pairs) >= 20, (len(got["tracked"]), len(got["truth"]))
    estimate, true = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    position = np.hypot(*(estimate[:, :2] - true[:, :2]).T)
    yaw = np.abs((estimate[:, 2] - true[:, 2] + math.pi) % (2 * math.pi) - math.pi)
    return position, yaw


def distances_to_target(got: dict[str, Any]) -> list[float]:
    """How far each ``/amcl_pose`` after the valid ``/initialpose`` is from the pose sent."""
    tx, ty, _ = got["target"]  # 0.5 m off the truth
    return [math.hypot(x - tx, y - ty) for _, x, y, _ in got["after"]]
