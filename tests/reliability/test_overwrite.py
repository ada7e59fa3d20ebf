"""Issue #38, kind 4: no command replaces an earlier output unless told to with ``--overwrite``.

For every command that writes files, an output that exists already is refused before the work,
in one line with exit 2, and left byte for byte as it was; with ``--overwrite`` it is replaced
(a file: new bytes the writer's format reads back; a bag: the earlier files gone, a bag there; a
training run: the earlier run's files gone, the user's own kept). Every command with an output
option has the one ``--overwrite`` flag with the one help text (``bubblerob_cli/outputs.py``).
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import pytest
from reliability_helpers import one_line, run

from bubblerob_cli import export
from bubblerob_cli.main import build_parser
from bubblerob_cli.outputs import OVERWRITE_HELP
from bubblerob_cli.train import build_parser as train_parser

ROOT = Path(__file__).resolve().parents[2]
SHORT = '{"max_episode_steps": 5}'
EARLIER = b"an earlier output\n"


def _digest(path: Path) -> str:
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    return hashlib.sha256(b"".join(str(p).encode() + p.read_bytes() for p in files)).hexdigest()


def _export(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            status = export.main(list(argv))
        except SystemExit as exit_:
            status = int(exit_.code or 0)
    return status, out.getvalue(), err.getvalue()


def _earlier_bag(path: Path) -> None:
    path.mkdir(parents=True)
    (path / "earlier.mcap").write_bytes(EARLIER)


def _earlier_run(path: Path) -> None:
    path.mkdir(parents=True)
    (path / "best_model.zip").write_bytes(EARLIER)  # a best model this run never writes
    (path / "notes.txt").write_bytes(EARLIER)


def _png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _bag(path: Path) -> bool:
    return not (path / "earlier.mcap").exists() and (path / "metadata.yaml").is_file()


def _run_replaced(path: Path) -> bool:
    kept = (path / "notes.txt").read_bytes() == EARLIER
    return kept and not (path / "best_model.zip").exists() and (path / "model.zip").is_file()


@dataclass(frozen=True)
class Case:
    """A command, the output it writes in ``tmp`` (made earlier), and how to read it back."""

    argv: Callable[[Path, Path], list[str]]  # (bag, tmp) -> argv, the output last but one
    output: str
    earlier: Callable[[Path], None]
    replaced: Callable[[Path], bool] | None  # None: a refusal follows (no terminal)
    statuses: tuple[int, ...] = (0,)


CASES = {
    "map --out": Case(
        lambda bag, tmp: ["map", str(bag), "--out", str(tmp / "m.png")],
        "m.png",
        lambda p: p.write_bytes(EARLIER),
        _png,
    ),
    "localize --out": Case(  # 12 steps need not converge: exit 1 with the picture written
        lambda bag, tmp: ["localize", str(bag), "--out", str(tmp / "l.png")],
        "l.png",
        lambda p: p.write_bytes(EARLIER),
        _png,
        (0, 1),
    ),
    "evaluate --per-episode": Case(
        lambda bag, tmp: [
            "evaluate",
            "--policy",
            "reactive",
            "--episodes",
            "1",
            "--env-kwargs",
            SHORT,
            "--per-episode",
            str(tmp / "e.json"),
        ],  # fmt: skip
        "e.json",
        lambda p: p.write_bytes(EARLIER),
        lambda p: len(json.loads(p.read_text())["reactive"]) == 1,
    ),
    "demo --out": Case(
        lambda bag, tmp: [
            "demo",
            "--policy",
            "reactive",
            "--episodes",
            "1",
            "--no-video",
            "--env-kwargs",
            SHORT,
            "--out",
            str(tmp),
        ],  # fmt: skip
        "bubblerob_demo_reactive",
        _earlier_bag,
        _bag,
    ),
    "record --out": Case(
        lambda bag, tmp: [
            "record",
            "--policy",
            "reactive",
            "--max-steps",
            "3",
            "--no-progress",
            "--out",
            str(tmp),
        ],  # fmt: skip
        "bubblerob_reactive_seed0",
        _earlier_bag,
        _bag,
    ),
    "teleop --record": Case(
        lambda bag, tmp: ["teleop", "--record", str(tmp / "drive")],
        "drive",
        _earlier_bag,
        None,
    ),
    "train --out": Case(
        lambda bag, tmp: [
            "train",
            "--timesteps",
            "8",
            "--n-envs",
            "1",
            "--set",
            "n_steps=8",
            "--set",
            "batch_size=8",
            "--eval-freq",
            "100000",
            "--no-progress",
            "--out",
            str(tmp / "run"),
        ],  # fmt: skip
        "run",
        _earlier_run,
        _run_replaced,
    ),
    "export --out": Case(
        lambda bag, tmp: [
            str(ROOT / "policies" / "trained" / "ppo_bubblerob_v0.zip"),
            "--out",
            str(tmp / "p.onnx"),
        ],  # fmt: skip
        "p.onnx",
        lambda p: p.write_bytes(EARLIER),
        lambda p: p.stat().st_size > 1000,
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_an_existing_output_is_refused_and_replaced_only_with_overwrite(
    name: str, short_bag, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if name.startswith("train"):
        pytest.importorskip("stable_baselines3")
    monkeypatch.chdir(tmp_path)
    case = CASES[name]
    output = tmp_path / case.output
    case.earlier(output)
    before = _digest(output)
    argv = case.argv(short_bag(), tmp_path)
    command = _export if name.startswith("export") else run
    status, out, err = command(*argv)
    assert status == 2 and "already exists" in err and "--overwrite" in err, (status, err)
    assert one_line(err) or err.count("\n") == 1, err  # export: not a bubblerob subcommand
    assert str(output) in err
    assert _digest(output) == before  # untouched
    status, out, err = command(*argv, "--overwrite")
    if case.replaced is None:  # teleop: refused for the terminal, after the output's check
        assert status == 2 and "terminal" in err and _digest(output) == before, err
        return
    assert status in case.statuses, err
    assert _digest(output) != before and case.replaced(output), err


def _writing_options(parser: argparse.ArgumentParser) -> set[str]:
    names = {o for action in parser._actions for o in action.option_strings}
    return names & {"--out", "--per-episode", "--video", "--record"}


def test_every_command_that_writes_has_the_one_overwrite_flag() -> None:
    parser = build_parser()
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    writers = {name: p for name, p in commands.choices.items() if _writing_options(p)}
    writers |= {"export": export.build_parser(), "python -m train": train_parser()}
    assert {"map", "localize", "evaluate", "demo", "record", "teleop", "train"} <= set(writers)
    for name, sub in writers.items():
        helps = [a.help for a in sub._actions if "--overwrite" in a.option_strings]
        assert helps == [OVERWRITE_HELP], name


def test_a_full_disk_while_training_is_one_line(tmp_path: Path) -> None:
    """RLIMIT_FSIZE (Python ignores SIGXFSZ, so a write fails): one line, exit 1, no traceback."""
    pytest.importorskip("stable_baselines3")
    import resource
    import subprocess
    import sys

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))

    done = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", *CASES["train --out"].argv(tmp_path, tmp_path)],
        preexec_fn=small_files,  # noqa: PLW1509
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [line for line in done.stderr.splitlines() if line.startswith("bubblerob train: ")]
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines == ["bubblerob train: training stopped: File too large"], done.stderr


@pytest.mark.parametrize("stdout", ["full", "closed"])
def test_export_reports_standard_output_in_one_line(stdout: str, tmp_path: Path) -> None:
    """``python -m policies.export_onnx`` (as ``python -m train``) guards standard output too."""
    import os
    import subprocess
    import sys

    target = open("/dev/full", "w") if stdout == "full" else None  # noqa: SIM115
    out = tmp_path / "p.onnx"
    try:
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "policies.export_onnx",
                *CASES["export --out"].argv(tmp_path, tmp_path),
            ],
            stdout=target if target is not None else subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=None if target is not None else (lambda: os.close(1)),  # noqa: PLW1509
            timeout=300,
            cwd=ROOT,
        )
    finally:
        if target is not None:
            target.close()
    lines = [line for line in done.stderr.splitlines() if "Warning" not in line]
    assert done.returncode == 1 and len(lines) == 1, done.stderr
    assert lines[0].startswith("python -m policies.export_onnx: ") and "standard output" in lines[0]
    assert out.exists() == (stdout == "full")  # closed: refused before the export


def test_a_full_disk_under_evaluate_robots_per_episode_is_one_line(tmp_path: Path) -> None:
    """The several-robot table is printed, then the --per-episode write fails: one line, exit 1."""
    pytest.importorskip("pettingzoo")
    import resource
    import subprocess
    import sys

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))

    out = tmp_path / "robots.json"
    argv = ["evaluate", "--robots", "4", "--policy", "laser", "--episodes", "3"]
    done = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", *argv, "--per-episode", str(out)],
        preexec_fn=small_files,  # noqa: PLW1509
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        f"bubblerob evaluate: cannot write --per-episode {out}: File too large"
    ), done.stderr
    assert "laser" in done.stdout  # the table came first
