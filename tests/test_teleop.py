"""``bubblerob teleop`` in a real terminal: tmux sends keys, reads the screen and the final pose."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from teleop_terminal import screen_until, tmux

from bubblerob_cli.teleop.keys import TeleopState

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux")


def test_keys_change_the_twist():
    state = TeleopState()
    for key in b"www":
        state.press(key)
    state.press(ord("a"))
    assert (state.linear, state.angular) == (pytest.approx(0.3), pytest.approx(0.1))
    state.press(ord(" "))
    assert (state.linear, state.angular) == (0.0, 0.0)
    for _ in range(20):
        state.press(ord("W"))
    assert state.linear == 1.0
    state.press(ord("q"))
    assert state.quit


TELEOP = (
    f"{sys.executable} -m bubblerob_cli teleop --start-pose 0 0 1.5708 "
    "--num-obstacles 0 0 --seed 0 --max-seconds 60"
)
"""Start at the centre facing +y (yaw pi/2), no obstacles: forward must move +y, not x."""


def test_forward_keys_drive_along_the_start_heading(tmp_path: Path):
    session = f"bubblerob-teleop-{id(tmp_path)}"
    bag = tmp_path / "drive"
    tmux("new-session", "-d", "-s", session, "-x", "200", "-y", "20",
         f"{TELEOP} --record {bag}; sleep 30")  # fmt: skip
    try:
        screen, _ = screen_until(session, "nearest", 30)
        assert "BubbleRob teleop" in screen and "collisions 0" in screen, repr(screen)
        tmux("send-keys", "-t", session, "w", "w", "w", "Up", "Up")  # forward 0.5
        # Real time: about 2 s (slower on a loaded machine).
        screen, _ = screen_until(session, r"pose x=\S+ y=(\S+)", 20, at_least=0.35)
        assert "cmd lin +0.5 ang +0.0" in screen, screen
        speed = float(re.search(r"speed ([+-][\d.]+) m/s", screen).group(1))
        assert speed > 0.1, screen
        tmux("send-keys", "-t", session, "Space")
        time.sleep(1.0)
        tmux("send-keys", "-t", session, "q")
        # curses gives the screen back, then the pose is printed
        text, _ = screen_until(session, "final pose", 20)
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], check=False, timeout=30)
    match = re.search(r"final pose: x=(\S+) y=(\S+) yaw=(\S+)", text)
    assert match, text
    x, y, yaw = (float(v) for v in match.groups())
    assert y > 0.3, text  # forward along the start heading (+y)
    assert abs(x) < 0.1 * y, text  # no sideways drift
    assert abs(yaw - math.pi / 2) < 0.1, text
    print(f"keys w w w Up Up, until y >= 0.35, Space, q -> final pose x={x} y={y} yaw={yaw}")
    # The recorded bag's last /odom pose is the printed one.
    rosbags = pytest.importorskip("rosbags.highlevel")
    with rosbags.AnyReader([bag]) as reader:
        odom = [c for c in reader.connections if c.topic == "/odom"]
        last = None
        for connection, _, raw in reader.messages(connections=odom):
            last = reader.deserialize(raw, connection.msgtype)
    assert last is not None
    assert last.pose.pose.position.x == pytest.approx(x, abs=1e-3)
    assert last.pose.pose.position.y == pytest.approx(y, abs=1e-3)


def test_ctrl_c_quits_as_q_without_a_traceback_and_keeps_the_bag(tmp_path: Path):
    # A user's Ctrl-C is not an error: the final pose is printed, the recorded drive is readable.
    session = f"bubblerob-teleop-c-{id(tmp_path)}"
    bag = tmp_path / "drive"
    log = tmp_path / "out.txt"
    tmux("new-session", "-d", "-s", session, "-x", "200", "-y", "20",
         f"{TELEOP} --record {bag} 2> {log}; echo exit=$?; sleep 30")  # fmt: skip
    try:
        screen_until(session, "nearest", 30)
        tmux("send-keys", "-t", session, "w", "w")
        time.sleep(1.5)
        tmux("send-keys", "-t", session, "C-c")
        text, _ = screen_until(session, "exit=", 20)
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], check=False, timeout=30)
    assert "exit=0" in text, text
    match = re.search(r"final pose: x=(\S+) y=(\S+) yaw=(\S+)", text)
    assert match and float(match.group(2)) > 0.05, text
    assert "Traceback" not in log.read_text() + text
    info = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "info", str(bag)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert info.returncode == 0 and "/odom" in info.stdout, info.stdout + info.stderr


@pytest.mark.parametrize("command", [["teleop"], ["teleop", "--ros", "1"], ["node"]])
def test_old_style_env_key_json_is_one_line_naming_env_kwargs(command, capsys):
    # `node --env KEY=JSON` was the node's form; --env is now the env id, as evaluate's.
    pytest.importorskip("rosbags")
    from bubblerob_cli import main as cli

    with pytest.raises(SystemExit) as exit_:
        cli.main([*command, "--env", "num_obstacles=[0,0]"])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert "--env takes an env id" in lines[0]
    assert """--env-kwargs '{"num_obstacles": [0,0]}'""" in lines[0], lines[0]
