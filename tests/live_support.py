"""What the live ROS 1 (tests/live) and ROS 2 (tests/live2) tests share, on the pytest side.

Imported as a plain module (tests/ is on sys.path through tests/conftest.py).
``live_helpers`` and ``ros2_helpers`` add what differs: the ROS 1 master and Debian's tools, the
ROS 2 venv and its DDS domain. The clients they run share ``live_client_support``.
"""

from __future__ import annotations

import json
import math
import queue
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


class ClientServer:
    """A live client script in ``serve`` mode: one process for every subcommand of a session.

    A one-shot client pays its interpreter, its client library and its discovery of the graph
    (1-2 s) for each call; this one once. What a subcommand subscribed to or published goes with
    it, as at a one-shot client's exit (``live_client_support.serve``). A call that fails or
    times out stops the process; the next call starts another.
    """

    RESULT = "CLIENT-RESULT "  # live_client_support.RESULT

    def __init__(self, command: Sequence[str], env: Mapping[str, str], cwd: Path | None = None):
        self.command, self.env, self.cwd = [*command, "serve"], dict(env), cwd
        self.proc: subprocess.Popen[str] | None = None
        self.answers: queue.Queue[str | None] = queue.Queue()
        self.err: list[str] = []

    def _start(self) -> subprocess.Popen[str]:
        self.answers, self.err = queue.Queue(), []
        proc = subprocess.Popen(
            self.command, env=self.env, cwd=self.cwd, text=True,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )  # fmt: skip
        threading.Thread(
            target=self._answers, args=(proc.stdout, self.answers), daemon=True
        ).start()
        threading.Thread(target=self._errors, args=(proc.stderr, self.err), daemon=True).start()
        return proc

    def _answers(self, stream: Any, answers: queue.Queue[str | None]) -> None:
        for line in stream:
            if line.startswith(self.RESULT):
                answers.put(line[len(self.RESULT) :])
        answers.put(None)  # the process ended

    @staticmethod
    def _errors(stream: Any, into: list[str]) -> None:
        for line in stream:
            into.append(line)

    def call(self, args: Sequence[str], timeout: float) -> Any:
        """Run one subcommand; its JSON result (an assertion error if it failed)."""
        if self.proc is None or self.proc.poll() is not None:
            self.proc = self._start()
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(list(args)) + "\n")
        self.proc.stdin.flush()
        try:
            line = self.answers.get(timeout=timeout)
        except queue.Empty:
            line = json.dumps({"error": f"no answer within {timeout} s"})
        answer = json.loads(line) if line is not None else {"error": "the client exited"}
        if "ok" not in answer:
            self.close()
            stderr = "".join(self.err)[-6000:]
            raise AssertionError(f"client {list(args)} failed: {answer['error']}\n{stderr}")
        return answer["ok"]

    def close(self) -> None:
        """Stop the process (end of its input, then SIGTERM, then SIGKILL)."""
        if self.proc is not None:
            if self.proc.poll() is None and self.proc.stdin is not None:
                self.proc.stdin.close()
                try:
                    self.proc.wait(5.0)
                except subprocess.TimeoutExpired:
                    stop(self.proc, signal.SIGTERM, timeout=5.0)
            self.proc = None


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
