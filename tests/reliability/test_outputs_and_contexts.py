"""Kinds 4, 5 and 7 of issue #38: outputs checked before the work, contexts refused at start.

Every output option (``map --out``, ``localize --out``, ``evaluate --per-episode`` and
``--video``) pointed at what it must never write (a recording, a directory, ``/proc``, an unknown
suffix, an earlier output without ``--overwrite``) is refused in one line, exit 2, before any
episode runs or bag is read, and the target is left byte for byte as it was (Hypothesis draws the
option and the target). Standard output full
or closed is one line. ``record``/``node`` with flat observations, no display for
``render_mode="human"``, a map too coarse to localise on: refused at start. A sample of the
hostile campaign (``bench/hostile``) runs here; the whole campaign is a bench run.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reliability_helpers import one_line, run

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench" / "hostile"))

import run as campaign  # noqa: E402 - bench/hostile/run.py


def _digest(path: Path) -> str:
    if path.is_dir():
        return "dir:" + ",".join(sorted(p.name for p in path.iterdir()))
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else "absent"


TARGETS = ("bag file", "bag folder file", "directory", "proc", "suffix", "earlier output")
COMMANDS = ("map --out", "localize --out", "evaluate --per-episode", "evaluate --video")


@settings(max_examples=12, deadline=None)
@given(command=st.sampled_from(COMMANDS), target=st.sampled_from(TARGETS))
def test_every_output_option_is_checked_before_the_work(
    short_bag, tmp_path_factory, command, target
):
    bag = short_bag()
    folder = tmp_path_factory.mktemp("out")
    wanted = {"map --out": ".png", "localize --out": ".png", "evaluate --per-episode": ".json"}.get(
        command, ".mp4"
    )
    path = {
        "bag file": next(bag.glob("*.mcap")),
        "bag folder file": bag / f"notes{wanted}",
        "directory": folder,
        "proc": Path("/proc/no/such") / f"x{wanted}",
        "suffix": folder / "x.unknown",
        "earlier output": folder / f"earlier{wanted}",  # written below: no --overwrite given
    }[target]
    if target == "earlier output":
        path.write_bytes(b"an earlier output\n")
    before = {p: _digest(p) for p in (bag, path)}
    name, option = command.split(" ")
    head = (
        [name, str(bag)]
        if name != "evaluate"
        else [name, "--policy", "reactive", "--episodes", "1"]
    )
    status, out, err = run(*head, option, str(path))
    assert status == 2 and one_line(err) and err.startswith(f"bubblerob {name}: "), err
    assert "episode" not in out and "IoU" not in out  # nothing ran
    assert {p: _digest(p) for p in (bag, path)} == before


def test_the_same_file_twice_is_refused(tmp_path: Path) -> None:
    same = str(tmp_path / "e.json")
    status, _, err = run("evaluate", "--policy", "reactive", "--per-episode", same, "--video", same)
    assert status == 2 and one_line(err) and "--video" in err


@pytest.mark.parametrize("stdout", ["full", "closed"])
def test_standard_output_full_or_closed_is_one_line(short_bag, stdout: str) -> None:
    target = open("/dev/full", "w") if stdout == "full" else None  # noqa: SIM115
    try:
        done = subprocess.run(
            [sys.executable, "-m", "bubblerob_cli", "info", str(short_bag())],
            stdout=target if target is not None else subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=None if target is not None else (lambda: os.close(1)),  # noqa: PLW1509
            timeout=120,
        )
    finally:
        if target is not None:
            target.close()
    assert done.returncode == 1, done.stderr
    assert done.stderr.count("\n") == 1 and "bubblerob info: " in done.stderr
    assert "standard output" in done.stderr


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["record", "--env-kwargs", '{"obs_mode": "flat"}'], "obs_mode"),
        (["record", "--env-kwargs", '{"render_mode": "human"}'], "no display"),
        (["evaluate", "--env-kwargs", '{"render_mode": "human"}'], "no display"),
        (["node", "--localize", "track", "--map-resolution", "1"], "too coarse"),
        (["node", "--env-kwargs", '{"obs_mode": "flat"}'], "obs_mode"),
        (["record", "--camera", "--env-kwargs", '{"camera": false}'], "contradicts"),
        (["node", "--env-kwargs", '{"max_episode_steps": 9}'], "contradicts"),
    ],
)
def test_contexts_that_cannot_work_are_refused_at_start(tmp_path, monkeypatch, argv, says):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.chdir(tmp_path)
    extra = {
        "record": ["--policy", "reactive", "--episodes", "1", "--out", "bags"],
        "evaluate": ["--policy", "reactive", "--episodes", "1"],
        "node": ["--max-steps", "3"],
    }[argv[0]]
    status, _, err = run(*argv, *extra)
    assert status == 2 and one_line(err) and says in err, err
    assert list(tmp_path.iterdir()) == []  # no bag folder left behind


def test_a_sample_of_the_hostile_campaign(tmp_path: Path) -> None:
    cases = campaign.load_cases(campaign.HERE / "cases.json")
    assert len(cases) >= 300
    plain = [
        c for c in cases if "argv" in c and "{" not in "".join(c["argv"]) and "stdout" not in c
    ]
    sample = [plain[k] for k in range(0, len(plain), max(1, len(plain) // 3))][:3]
    results = [campaign.run_case(case, {}, tmp_path) for case in sample]
    snippets = [c for c in cases if "python" in c][::25]
    results += campaign.run_snippets(snippets, {}, tmp_path)
    assert [r["verdict"] for r in results] == ["ok"] * len(results), results


def test_a_write_that_fails_after_the_work_is_one_line(tmp_path: Path) -> None:
    """A full disk (RLIMIT_FSIZE: Python ignores SIGXFSZ, so the write fails) at the end."""
    import resource

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (50, 50))

    out = tmp_path / "e.json"
    done = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "evaluate", "--policy", "reactive"]
        + ["--episodes", "1", "--per-episode", str(out)],
        preexec_fn=small_files,  # noqa: PLW1509
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert done.returncode == 1, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("bubblerob ")]
    assert lines == [f"bubblerob evaluate: cannot write --per-episode {out}: File too large"]
    assert "Traceback" not in done.stderr
