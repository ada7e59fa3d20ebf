"""A bag written by a process of its own (``writer="process"``): the same bytes, the same errors.

The crash-safety guarantees with a writer process (signals, hard kill) are checked in
``test_crash_safety.py``, next to the inline writer's.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.bags.lock import BagLockedError
from bubblerob_env.ros.bags.process import WriterDiedError
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.readback.summary import read_summary


def _record(path, fmt, compression, writer, camera=False, steps=300):
    env = RosBagRecorder(
        gym.make("BubbleRob-v0", max_episode_steps=70, camera=camera),
        path,
        topics=Topics(detections=None),
        format=fmt,
        compression=compression,
        writer=writer,
        start_time=1.7e9,
        metadata={"policy": "test"},
    )
    env.reset(seed=3)
    actions = np.random.default_rng(0).uniform(-0.2, 1.0, size=(steps, 2)).astype(np.float32)
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    env.close()


@pytest.mark.parametrize(
    ("fmt", "compression", "camera"),
    [
        ("mcap", "zstd", False),
        ("mcap", "zstd", True),  # batches of images through the shared memory
        ("mcap", "none", False),
        ("sqlite3", None, False),
        ("ros1", "lz4", False),
    ],
)
def test_the_same_bytes_as_the_inline_writer(tmp_path, fmt, compression, camera):
    files = {}
    for writer in ("inline", "process"):
        root = tmp_path / writer
        _record(root / "bag", fmt, compression, writer, camera)
        files[writer] = {
            p.relative_to(root): p.read_bytes() for p in root.rglob("*") if p.is_file()
        }
    assert len(files["inline"]) >= 1
    assert files["process"] == files["inline"]


def test_a_writer_that_dies_is_reported_not_waited_on(tmp_path):
    env = RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", writer="process")
    env.reset(seed=0)
    (writer,) = multiprocessing.active_children()
    os.kill(writer.pid, signal.SIGKILL)
    writer.join(timeout=10)
    said = r"writing bag .*bag was killed by signal 9: the bag is unfinished"
    with pytest.raises(WriterDiedError, match=said):
        for _ in range(400):  # the first batch sent finds it gone
            env.step(np.array([0.5, 0.5], dtype=np.float32))
    with pytest.raises(WriterDiedError, match=said):  # and closing says so again
        env.close()
    env.close()  # then closing again does nothing


FULL_DISK = textwrap.dedent(
    """
    import resource, signal, sys
    import gymnasium as gym
    import numpy as np
    import bubblerob_env
    from bubblerob_env.ros import RosBagRecorder

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes fail with EFBIG, as on a full disk
    resource.setrlimit(resource.RLIMIT_FSIZE, (150_000, 150_000))
    env = RosBagRecorder(
        gym.make("BubbleRob-v0", max_episode_steps=30), "bag", writer=sys.argv[1]
    )
    env.reset(seed=0)
    try:
        for _ in range(3000):
            _, _, terminated, truncated, _ = env.step(np.array([0.5, 0.5], dtype=np.float32))
            if terminated or truncated:
                env.reset()
        env.close()
    except OSError as error:
        print(type(error).__name__, error)
    try:
        env.close()
    except OSError as error:
        print("close:", type(error).__name__, error)
    print("saved", env.completed_episodes)
    """
)


def test_a_full_disk_gives_the_inline_writers_error(tmp_path):
    said = {}
    for writer in ("inline", "process"):
        (tmp_path / writer).mkdir()
        run = subprocess.run(
            [sys.executable, "-c", FULL_DISK, writer],
            cwd=tmp_path / writer,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert run.returncode == 0, run.stderr
        said[writer] = run.stdout.splitlines()
    assert said["inline"] and "File too large" in said["inline"][0]
    assert said["process"] == said["inline"]
    # What the recorder says it saved is what reads back (the writer's flushes, not the hand-overs)
    saved = int(said["process"][-1].split()[1])
    for writer in ("inline", "process"):
        assert saved >= 2 and len(read_summary(tmp_path / writer / "bag").episodes) == saved


def test_the_recording_process_holds_the_bags_lock(tmp_path):
    env = RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", writer="process")
    try:
        assert (tmp_path / "bag.lock").read_text() == str(os.getpid())  # not the writer's pid
        with pytest.raises(BagLockedError, match=f"being written by process {os.getpid()};"):
            RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", overwrite=True)
    finally:
        env.close()
    assert not (tmp_path / "bag.lock").exists()


DEFAULT_WRITER = textwrap.dedent(
    """
    import os, threading
    import gymnasium as gym
    import bubblerob_env
    from bubblerob_env.ros import RosBagRecorder

    def writer(name):
        env = RosBagRecorder(gym.make("BubbleRob-v0"), name)
        env.close()
        return env.writer

    said = [writer("cores")]
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()  # a fork copies only the forking thread
    said.append(writer("thread"))
    stop.set()
    thread.join()
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core: nothing to gain
    said.append(writer("one_core"))
    print(*said)
    """
)


@pytest.mark.skipif(
    not hasattr(os, "sched_getaffinity") or len(os.sched_getaffinity(0)) < 2,
    reason="needs two usable cores",
)
def test_the_default_writer_is_a_process_where_it_helps_and_is_safe(tmp_path):
    run = subprocess.run(
        [sys.executable, "-c", DEFAULT_WRITER],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["process", "inline", "inline"]


def test_the_benchmark_measures_the_writer_process():
    root = Path(__file__).resolve().parents[2]
    run = subprocess.run(
        [sys.executable, str(root / "bench" / "record_speed.py"), "--quick", "--no-detections"]
        + ["--writer", "process"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert "recording over the plain env (MCAP zstd, camera off): " in run.stdout
