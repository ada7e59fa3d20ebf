"""A bag survives exceptions, Ctrl-C and SIGTERM with every completed step in it."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from mcap.exceptions import EndOfFile
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from ros_helpers import FORWARD, missing_debian_ros, read_all, run_debian

from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary

CHILD = textwrap.dedent(
    """
    import sys
    import gymnasium as gym
    import numpy as np
    import bubblerob_env
    from bubblerob_env.ros import RosBagRecorder

    path, fmt, mode, writer = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
    env = RosBagRecorder(
        gym.make("BubbleRob-v0", max_episode_steps=40), path, format=fmt, writer=writer
    )
    env.reset(seed=0)
    action = np.array([0.6, 0.5], dtype=np.float32)
    step = 0
    while True:  # never closes the recorder itself
        _, _, terminated, truncated, _ = env.step(action)
        step += 1
        print(step, flush=True)
        if terminated or truncated:
            env.reset()
        if mode == "raise" and step == 25:
            raise RuntimeError("the training loop crashed")
    """
)


def _frames(path):
    messages = read_all(path)
    steps = len(messages["/cmd_vel"])
    resets = len(read_summary(path).episodes)
    # Every completed step is whole: its action, its observation and its reward are all there.
    for topic in ("/bubblerob/action", "/reward", "/terminated", "/leftMotorSpeed"):
        assert len(messages[topic]) == steps, topic
    for topic in ("/scan", "/odom", "/tf", "/clock", "/proximity"):
        assert len(messages[topic]) == steps + resets, topic
    return steps


def _run_child(tmp_path, fmt, mode, signum=None, at_step=60, writer="inline"):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    bag = tmp_path / "bag"
    child = subprocess.Popen(
        [sys.executable, str(script), str(bag), fmt, mode, writer],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        bufsize=0,  # unbuffered: lines read ahead of the signal would be lost to communicate()
    )
    printed = []
    assert child.stdout is not None
    for line in iter(child.stdout.readline, b""):  # a raw pipe reads no further than each line
        printed.append(int(line))
        if signum is not None and printed[-1] == at_step:
            child.send_signal(signum)
            break
    out, err_bytes = child.communicate(timeout=60)
    err = err_bytes.decode()
    printed += [int(line) for line in out.split()]
    return child.returncode, printed[-1], err, bag


def _episode_ends(steps: int) -> list[int]:
    """Steps at which the child's episodes end (it is deterministic: same env, seed, action)."""
    env = gym.make("BubbleRob-v0", max_episode_steps=40)
    env.reset(seed=0)
    ends = []
    for step in range(1, steps + 1):
        _, _, terminated, truncated, _ = env.step(np.array([0.6, 0.5], dtype=np.float32))
        if terminated or truncated:
            ends.append(step)
            env.reset()
    return ends


def _cmd_vel_after_hard_kill(path, fmt: str) -> int:
    """Steps a killed recording kept, read as a user would recover them (the index is missing)."""
    if fmt == "mcap":  # no summary: read the records in order, as `mcap recover` does
        topics: dict[int, str] = {}
        count = 0
        with open(next(path.glob("*.mcap")), "rb") as stream:
            try:
                for record in StreamReader(stream).records:  # chunks come decompressed
                    if isinstance(record, Channel):
                        topics[record.id] = record.topic
                    elif isinstance(record, Message):
                        count += topics[record.channel_id] == "/cmd_vel"
            except EndOfFile:  # the file stops after the last flushed chunk
                pass
        return count
    if fmt == "sqlite3":  # committed rows; metadata.yaml comes with close
        with sqlite3.connect(next(path.glob("*.db3"))) as db:
            query = "SELECT COUNT(*) FROM messages JOIN topics ON topic_id = topics.id"
            return int(db.execute(query + " WHERE name = '/cmd_vel'").fetchone()[0])
    result = run_debian("/usr/bin/rosbag", "reindex", str(path))  # Debian's real tool
    assert result.returncode == 0, result.stderr
    return len(read_all(path)["/cmd_vel"])


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3", "ros1"])
def test_uncaught_exception_leaves_a_complete_bag(tmp_path, fmt):
    returncode, last, err, bag = _run_child(tmp_path, fmt, "raise")
    assert returncode == 1 and "the training loop crashed" in err
    path = bag.with_suffix(".bag") if fmt == "ros1" else bag
    assert _frames(path) == last == 25


@pytest.mark.parametrize(
    ("fmt", "writer"),
    [("mcap", "inline"), ("sqlite3", "inline"), ("ros1", "inline"), ("mcap", "process")],
)
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_leaves_a_bag_with_every_completed_step(tmp_path, fmt, writer, signum):
    returncode, last, err, bag = _run_child(tmp_path, fmt, "loop", signum, writer=writer)
    if signum == signal.SIGTERM:
        assert returncode == 128 + signal.SIGTERM, err
    else:
        assert returncode in (1, -signal.SIGINT) and "KeyboardInterrupt" in err
    path = bag.with_suffix(".bag") if fmt == "ros1" else bag
    steps = _frames(path)
    assert last <= steps <= last + 1  # the step under way when the signal came is finished


@pytest.mark.parametrize(
    ("fmt", "writer"),
    [
        ("mcap", "inline"),
        ("sqlite3", "inline"),
        pytest.param(  # recovered with Debian's rosbag reindex
            "ros1",
            "inline",
            marks=pytest.mark.skipif(missing_debian_ros() is not None, reason="no rosbag"),
        ),
        ("mcap", "process"),  # the writer process reads what was sent, then stops unfinished
    ],
)
def test_hard_kill_loses_at_most_the_current_episode(tmp_path, fmt, writer):
    # SIGKILL cannot be caught: the bag keeps what was flushed at the end of each episode.
    returncode, last, _, bag = _run_child(
        tmp_path, fmt, "loop", signal.SIGKILL, at_step=100, writer=writer
    )
    assert returncode == -signal.SIGKILL
    path = bag.with_suffix(".bag") if fmt == "ros1" else bag
    ends = _episode_ends(last + 41)
    # Our own reader first, read-only: every complete episode, nothing of the unfinished one.
    before = sorted(
        (p.name, p.stat().st_size) for p in ([path] if path.is_file() else path.iterdir())
    )
    summary = read_summary(path)
    report = replay_bag(path)
    after = sorted(
        (p.name, p.stat().st_size) for p in ([path] if path.is_file() else path.iterdir())
    )
    assert after == before  # nothing written: no journal rolled back, no index added
    assert summary.unfinished and report.unfinished and report.ok, report
    assert "unfinished recording" in str(report)
    complete = len(summary.episodes)
    assert report.episodes == complete and report.steps == ends[complete - 1]
    counts = {t.name: t.count for t in summary.topics}
    assert counts["/cmd_vel"] == ends[complete - 1]
    assert counts["/scan"] == ends[complete - 1] + complete and counts["/tf_static"] == 1
    kept = _cmd_vel_after_hard_kill(path, fmt)  # then the formats' own recovery
    # every episode that ended before the kill, or the one ending at the step it was printing
    assert kept in (max(end for end in ends if end <= last), min(e for e in ends if e > last))
    assert kept >= ends[1]
    assert kept == ends[complete - 1]  # we read what the recovery tools recover


def test_exception_inside_with_block_closes_the_bag(tmp_path):
    env = gym.make("BubbleRob-v0")
    with pytest.raises(RuntimeError), RosBagRecorder(env, tmp_path / "bag") as recorder:
        recorder.reset(seed=0)
        for _ in range(7):
            recorder.step(FORWARD)
        raise RuntimeError("policy failed")
    assert _frames(recorder.bag_paths[0]) == 7


class _DropsInfoKey(gym.Wrapper):
    """Step 5 returns an info without ``proximity_triggered``: a frame no bag can hold."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.steps = 0

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.steps += 1
        if self.steps == 5:
            info = {k: v for k, v in info.items() if k != "proximity_triggered"}
        return obs, reward, terminated, truncated, info


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_a_bad_frame_raises_at_its_step_and_the_bag_keeps_the_steps_before(tmp_path, fmt):
    # Frames are recorded in batches: a bad one must fail at once, not when the batch is written.
    recorder = RosBagRecorder(_DropsInfoKey(gym.make("BubbleRob-v0")), tmp_path / "bag", format=fmt)
    recorder.reset(seed=0)
    for _ in range(4):
        recorder.step(FORWARD)
    with pytest.raises(KeyError, match="proximity_triggered"):
        recorder.step(FORWARD)
    recorder.close()
    assert _frames(recorder.bag_paths[0]) == 4


def test_signal_handlers_are_restored_after_close(tmp_path):
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    recorder = RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag")
    assert signal.getsignal(signal.SIGTERM) is not before[0]
    recorder.close()
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before


def _cut(path, fmt, size):
    """A copy of a finished bag cut after ``size`` bytes, as a killed recorder leaves it."""
    if fmt == "ros1":
        cut = path.with_name(f"cut_{size}.bag")
        cut.write_bytes(path.read_bytes()[:size])
        return cut
    cut = path.with_name(f"cut_{size}")
    cut.mkdir()
    source = next(path.glob("*.mcap"))
    (cut / source.name).write_bytes(source.read_bytes()[:size])  # no metadata.yaml
    return cut


@pytest.mark.parametrize(
    ("fmt", "compression"), [("mcap", "zstd"), ("mcap", "none"), ("ros1", "bz2"), ("ros1", "lz4")]
)
def test_bags_cut_anywhere_read_their_complete_episodes(record, fmt, compression):
    bag = record(fmt, compression, episodes=4, steps=99, env_kwargs={"max_episode_steps": 12})
    data = next(bag.glob("*.mcap")).read_bytes() if fmt == "mcap" else bag.read_bytes()
    seen = []
    for size in range(len(data) // 9, len(data), len(data) // 9):
        cut = _cut(bag, fmt, size)
        summary = read_summary(cut)
        assert summary.unfinished
        complete = len(summary.episodes)
        counts = {t.name: t.count for t in summary.topics}
        assert counts.get("/cmd_vel", 0) == 12 * complete
        assert counts.get("/scan", 0) == 13 * complete
        if complete:
            report = replay_bag(cut)
            assert report.ok and report.episodes == complete, report
        seen.append(complete)
    assert seen == sorted(seen) and seen[-1] >= 3  # more file, more episodes; nearly all at the end
