"""``bubblerob record`` run as a user runs it: Ctrl-C, a second writer, a full disk, a bad --out.

Each ends in one line on stderr (no traceback) and a non-zero exit, and no finished episode is
lost. Subprocesses: signals and file-size limits are per process, and a lock is held by another
process than the one it blocks; what needs none of these runs in this one (``cli_usage.run``).
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from cli_usage import Exit, run

from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary

pytest.importorskip("policies")

RECORD = [sys.executable, "-m", "bubblerob_cli", "record", "--policy", "reactive"]


def _record(out: Path, *args: str, **kwargs: object) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [*RECORD, "--no-progress", "--out", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,  # type: ignore[call-overload]
    )


def _one_line(err: str) -> str:
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


def test_ctrl_c_says_what_was_saved_and_exits_130(tmp_path):
    proc = _record(tmp_path, "--episodes", "200", "--max-steps", "30", "--format", "ros1")
    bag = tmp_path / "bubblerob_reactive_seed0.bag"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not bag.exists() or bag.stat().st_size < 200_000):
        time.sleep(0.05)  # a few episodes flushed
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    line = _one_line(err)
    assert line.startswith("stopped: ") and line.endswith(f"complete episode(s) saved to {bag}")
    saved = int(line.split()[1])
    summary = read_summary(bag)
    assert not summary.unfinished and saved >= 1
    assert len(summary.episodes) in (saved, saved + 1)  # and the steps of the interrupted one
    assert replay_bag(bag).ok


HOLDER = textwrap.dedent(
    """
    import sys
    import gymnasium as gym
    import numpy as np
    import bubblerob_env
    from bubblerob_env.ros import RosBagRecorder

    env = gym.make("BubbleRob-v0", max_episode_steps=5)
    with RosBagRecorder(env, sys.argv[1], overwrite=True) as recorder:
        print("ready", flush=True)
        sys.stdin.readline()  # hold the bag until told
        recorder.reset(seed=3)
        for _ in range(5):
            recorder.step(np.array([0.5, 0.5], dtype=np.float32))
    print("closed", flush=True)
    """
)


def _holder(tmp_path: Path, bag: Path) -> subprocess.Popen[str]:
    script = tmp_path / "holder.py"
    script.write_text(HOLDER)
    proc = subprocess.Popen(
        [sys.executable, str(script), str(bag)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    return proc


def _record_here(out: Path, capsys: pytest.CaptureFixture[str], *args: str) -> Exit:
    return run(
        ["record", "--policy", "reactive", "--no-progress", "--out", str(out), *args], capsys
    )


def test_a_second_writer_fails_while_the_first_holds_the_bag(tmp_path, capsys):
    bag = tmp_path / "bubblerob_reactive_seed0"
    holder = _holder(tmp_path, bag)
    try:
        second = _record_here(tmp_path, capsys, "--overwrite", "--max-steps", "3")
        assert second.code == 2
        line = _one_line(second.err)
        assert f"bag {bag} is being written by process {holder.pid}" in line
        out, _ = holder.communicate("go\n", timeout=60)
    finally:
        holder.kill()
    assert holder.returncode == 0 and "closed" in out
    (episode,) = read_summary(bag).episodes  # the first writer's, whole
    assert episode["seed"] == 3 and replay_bag(bag).ok
    assert not Path(f"{bag}.lock").exists()
    third = _record_here(tmp_path, capsys, "--overwrite", "--max-steps", "3")  # free again
    assert third.code == 0, third.err
    assert read_summary(bag).episodes[0]["seed"] == 0


def test_a_killed_writers_lock_blocks_nobody(tmp_path, capsys):
    bag = tmp_path / "bubblerob_reactive_seed0"
    holder = _holder(tmp_path, bag)
    holder.kill()
    holder.wait(timeout=30)
    assert Path(f"{bag}.lock").exists()  # stale: the kernel dropped the lock with the process
    done = _record_here(tmp_path, capsys, "--overwrite", "--max-steps", "3")
    assert done.code == 0, done.err
    assert not Path(f"{bag}.lock").exists()


def test_an_unusable_out_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    done = _record_here(blocker / "bags", capsys, "--max-steps", "3")
    assert done.code == 2
    assert _one_line(done.err).startswith("bubblerob record: ") and str(blocker) in done.err


def _file_size_limit(limit: int):  # noqa: ANN202 - a preexec_fn
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes fail with EFBIG, as on a full disk

    return apply


@pytest.mark.parametrize(
    ("fmt", "compression"),
    [("mcap", "none"), ("mcap", "zstd"), ("sqlite3", "none"), ("ros1", "none")],
)
def test_a_full_disk_is_one_line_and_the_finished_episodes_read_back(tmp_path, fmt, compression):
    args = ["--episodes", "100", "--max-steps", "30", "--format", fmt, "--compression", compression]
    limit = 150_000 if compression == "zstd" else 600_000
    proc = _record(tmp_path, *args, preexec_fn=_file_size_limit(limit))
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err
    line = _one_line(err)
    reason = "sqlite3: disk I/O error" if fmt == "sqlite3" else "File too large"
    assert line.startswith(f"bubblerob record: {reason}"), line
    saved = int(line.split("; ")[1].split()[0])
    bag = tmp_path / ("bubblerob_reactive_seed0" + (".bag" if fmt == "ros1" else ""))
    summary = read_summary(bag)
    assert saved >= 2 and len(summary.episodes) == saved, (saved, summary)
    report = replay_bag(bag)
    assert report.ok and report.episodes == saved, report
    assert max(p.stat().st_size for p in ([bag] if bag.is_file() else bag.iterdir())) <= limit
    assert os.path.exists(bag)


def test_info_into_a_closed_pipe_is_quiet(record):
    bag = record("mcap", episodes=2, steps=3)
    shell = f"{sys.executable} -m bubblerob_cli info {bag} | head -1"
    result = subprocess.run(["bash", "-c", shell], capture_output=True, text=True, timeout=120)
    assert result.stdout.startswith("bag:") and result.stderr == "", result.stderr
