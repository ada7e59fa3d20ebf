"""README's commands are the ones CI runs, and its code runs."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
CI_SCRIPT = (ROOT / ".ci" / "run").read_text()


def _code_blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.DOTALL)


def _section_blocks(heading: str) -> list[str]:
    section = README.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)


def _section_block(heading: str) -> str:
    return _section_blocks(heading)[0]


def _commands(block: str) -> list[str]:
    return [line for line in block.splitlines() if line.strip() and not line.startswith("#")]


def _ci_commands() -> list[str]:
    return [line.strip() for line in CI_SCRIPT.splitlines() if line and not line.startswith("#")]


def _make(*args: str) -> subprocess.CompletedProcess[str]:
    # Not as a sub-make of `make test`: its variables (PYTEST_ARGS=...) would carry over, through
    # MAKEFLAGS and the environment.
    outer = {"MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES", "PYTEST_ARGS", "DEMO_ARGS"}
    outer |= {"VENV", "VENV_ROS2", "PYTHON", "TORCH_CPU_INDEX", "TORCH_FALLBACK"}
    env = {name: value for name, value in os.environ.items() if name not in outer}
    return subprocess.run(
        ["make", *args], capture_output=True, text=True, timeout=60, cwd=ROOT, env=env, check=False
    )


def _dry_run(goal: str) -> str:
    """What `make GOAL` would run, every branch of its recipes (make -n runs nothing)."""
    result = _make("-n", goal, "VENV=.venv", "VENV_ROS2=.venv-ros2", "PYTHON=python3")
    assert result.returncode == 0, result.stderr
    return result.stdout


def _position_in(dry_run: str, command: str, start: int) -> int:
    """Where README's by-hand COMMAND is in a make dry run, searching from START (-1: not there)."""
    if command == "source .venv/bin/activate":
        # make calls the venv's programs by path instead: `.venv/bin/pip install ...`
        return start
    if command == "apt-get update":
        # make's apt step runs it first, where any of its packages is missing
        return start if "apt-get update && " in dry_run else -1
    if command.startswith("apt-get install -y "):
        # make loops over the packages and apt-get installs the missing ones
        if "apt-get install -y $missing" not in dry_run:
            return -1
        packages = command.removeprefix("apt-get install -y ")
        return dry_run.find(f"for package in {packages};", start)
    return dry_run.find(command, start)


def _assert_make_runs_in_order(goal: str, commands: list[str]) -> None:
    dry_run, position = _dry_run(goal), 0
    for line in commands:
        for command in line.split(" && "):
            found = _position_in(dry_run, command, position)
            assert found >= 0, f"make {goal} does not run README's {command!r} (in this order)"
            position = found


def test_readme_shows_the_two_make_commands_first():
    assert _commands(_section_block("Set up")) == ["make demo", "make test"]
    assert _commands(_section_block("Run the demo")) == ["make demo"]
    assert _commands(_section_block("Run the tests")) == ["make test"]


def test_make_demo_runs_readmes_by_hand_steps_and_brings_no_torch():
    by_hand = _commands(_section_blocks("Set up")[1]) + _commands(
        _section_blocks("Run the demo")[1]
    )
    assert by_hand[-1] == "bubblerob demo"
    assert 'pip install -e ".[demo]"' in by_hand
    _assert_make_runs_in_order("demo", by_hand)
    assert "torch" not in _dry_run("demo")


def test_make_test_runs_readmes_by_hand_steps_then_pytest():
    by_hand = _commands(_section_blocks("Set up")[1]) + _commands(
        _section_blocks("Run the tests")[1]
    )
    assert by_hand[-1] == "python -m pytest"
    _assert_make_runs_in_order("test", by_hand)
    # README's CPU-only torch line (Set up's training block) is the one make test runs
    torch_line = _commands(_section_blocks("Set up")[2])[0]
    assert torch_line in by_hand
    assert _dry_run("test").rstrip().endswith("python -m pytest")


def test_make_test_clients_runs_the_client_tests_that_make_test_skips():
    # README's `make test-clients`: its venv gets CPU torch, the project, Tianshou and RLlib, then
    # pytest runs the tests that skip in make test (run for real: 2 passed in 6.5 min, before
    # test_rllib_multi.py joined them).
    assert "`make test-clients`" in README
    dry_run = _make("-n", "test-clients", "VENV_CLIENTS=.venv-clients").stdout
    assert "--index-url https://download.pytorch.org/whl/cpu" in dry_run
    assert '"tianshou[eval]==2.0.1" "ray[rllib]==2.60.0"' in dry_run
    tests = "tests/test_clients_tianshou.py tests/ray/test_rllib.py tests/ray/test_rllib_multi.py"
    assert dry_run.rstrip().endswith(f" {tests}")
    assert ".venv-clients/bin/python -m pytest tests/test_env.py " in dry_run
    skip = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-rs", *tests.split()],
        cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    if "3 passed" not in skip.stdout:  # where the clients are installed they run; else say why
        assert skip.stdout.count("make test-clients") == 3, skip.stdout


def test_ci_runs_make_demo_torch_free_then_make_test():
    ci = _ci_commands()
    demo = next(i for i, line in enumerate(ci) if line.startswith("make demo"))
    torch_check = next(i for i, line in enumerate(ci) if "find_spec('torch')" in line)
    assert demo < torch_check < len(ci) - 1
    assert ci[-1] == "make test"
    # every install goes through make: CI proves README's commands, not its own
    assert not [line for line in ci if re.match(r"(pip|apt-get|python3? -m (pip|venv)) ", line)]


def _stamped_venv(tmp_path: Path, stamp: str, inputs: str) -> Path:
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").symlink_to(sys.executable)
    (venv / stamp).write_text(inputs)
    return venv


def _sha256_line(path: str) -> str:
    return subprocess.run(
        ["sha256sum", path], capture_output=True, text=True, cwd=ROOT, check=True
    ).stdout


def test_make_skips_an_install_whose_stamp_matches_and_says_so(tmp_path):
    for stamp in (".stamp-demo", ".stamp-all"):  # [all] includes [demo]
        venv = _stamped_venv(tmp_path / stamp, stamp, _sha256_line("pyproject.toml"))
        result = _make("venv-demo", f"VENV={venv}")
        assert result.returncode == 0, result.stderr
        assert f"setup: {venv} exists: skipped" in result.stdout
        assert f"setup: {venv} has .[demo] for this pyproject.toml: skipped" in result.stdout


def test_make_installs_again_when_pyproject_changed(tmp_path):
    # A stamp for another pyproject.toml: the install runs (and fails here, the venv having no
    # pip), and no stamp is written for a step that failed.
    stale = "0" * 64 + "  pyproject.toml\n"
    venv = _stamped_venv(tmp_path, ".stamp-demo", stale)
    result = _make("venv-demo", f"VENV={venv}")
    assert result.returncode != 0
    assert f"setup: installing .[demo] into {venv}" in result.stdout
    assert (venv / ".stamp-demo").read_text() == stale


@pytest.mark.skipif(shutil.which("dpkg-query") is None, reason="needs Debian's dpkg-query")
def test_make_apt_installs_only_the_missing_packages():
    # SUDO=echo prints the apt-get commands instead of running them.
    result = _make("debs-demo", "DEMO_DEBS=coreutils no-such-package-bubblerob", "SUDO=echo")
    assert result.returncode == 0, result.stderr
    assert "installing Debian packages for rendering and videos: no-such-package" in result.stdout
    assert "apt-get install -y no-such-package-bubblerob\n" in result.stdout
    installed = _make("debs-demo", "DEMO_DEBS=coreutils", "SUDO=false")
    assert installed.returncode == 0, installed.stderr
    assert "Debian packages for rendering and videos are installed: skipped" in installed.stdout


def test_make_says_which_torch_is_installed():
    pytest.importorskip("torch")
    result = _make("torch", f"VENV={sys.prefix}")
    assert result.returncode == 0, result.stderr
    import torch

    build = "CPU-only build" if torch.version.cuda is None else f"CUDA {torch.version.cuda} build"
    assert f"setup: torch {torch.__version__} ({build}, " in result.stdout
    assert result.stdout.rstrip().endswith(f"is in {sys.prefix}: skipped")


def _run_python_block(code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    # As a script file: SubprocVecEnv's forkserver workers re-import the main script.
    script = tmp_path / "readme_block.py"
    script.write_text(code)
    return subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        check=False,
    )


def _python_block(marker: str) -> str:
    """README's one ```python block that contains ``marker`` (other sections have their own)."""
    (block,) = [b for b in _code_blocks("python") if marker in b]
    return block


def test_quickstart_runs(tmp_path):
    quickstart = _python_block('print(f"t={info')
    result = _run_python_block(quickstart, tmp_path)
    assert result.returncode == 0, result.stderr
    assert re.search(r"t=\d+\.\d\ds pose=\(", result.stdout)


def test_subprocess_vector_env_example_runs(tmp_path):
    subprocesses = _python_block("SubprocVecEnv")
    assert '"bubblerob_env:BubbleRob-v0"' in subprocesses
    assert 'if __name__ == "__main__":' in subprocesses
    result = _run_python_block(subprocesses, tmp_path)
    assert result.returncode == 0, result.stderr
    assert "laser batch (2, 360)" in result.stdout


def test_readme_figure_command_writes_the_picture(tmp_path):
    out = tmp_path / "arena.png"
    result = subprocess.run(
        [sys.executable, "docs/make_figures.py", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        env=os.environ,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "docs/make_figures.py" in README


def _run_section(heading: str, cwd: Path, block: int = 0) -> subprocess.CompletedProcess[str]:
    script = "set -euo pipefail\n" + _section_blocks(heading)[block]
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    return subprocess.run(
        ["bash", "-c", script],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )


def test_readme_record_info_replay_commands(tmp_path):
    result = _run_section("Record, inspect and replay bags", tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "bags" / "bubblerob_laser_seed0").is_dir()
    assert (tmp_path / "bags" / "bubblerob_reactive_seed5.bag").is_file()
    assert "/scan" in result.stdout


def test_readme_evaluate_and_train_commands(tmp_path):
    result = _run_section("Evaluate and train", tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "laser.gif").is_file()
    assert (tmp_path / "runs" / "quick" / "best_model.zip").is_file()
    assert result.stdout.count("policy") >= 2  # two tables


def test_readme_demo_command(tmp_path):
    result = _run_section("Run the demo", tmp_path, block=1)  # by hand: bubblerob demo
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo").is_dir()
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo.mp4").stat().st_size > 10_000
    assert "success" in result.stdout


def _markdown_rows(text: str) -> dict[str, list[str]]:
    rows = {}
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == 8 and cells[0] not in ("policy", "---"):
            rows[cells[0]] = cells[1:]
    return rows


POLICY_RESULTS = Path("docs") / "results" / "policies_test.json"


def test_readme_policy_table_is_its_per_episode_file():
    # README's table is the 1000 test episodes of docs/results/policies_test.json, aggregated.
    from policies.evaluation import format_table, summarize_records
    from policies.protocol import TEST

    section = README.split("## Policies\n", 1)[1].split("\n## ", 1)[0]
    stored = json.loads((ROOT / POLICY_RESULTS).read_text())
    table = format_table([summarize_records(p, r) for p, r in stored.items()], markdown=True)
    assert _markdown_rows(section) == _markdown_rows(table)
    assert set(stored) == {"reactive", "laser", "ppo", "random"}
    for records in stored.values():
        assert [r["seed"] for r in records] == list(range(TEST.start, TEST.start + 1000))


def test_readme_policy_command_reproduces_its_episodes(tmp_path):
    # README's command on its first 2 episodes (all 1000 take about 20 minutes), then 6 more
    # spread over the 1000, in process: each equals its stored record.
    from policies.evaluation import evaluate

    command = _section_blocks("Policies")[0]
    assert "--episodes 1000" in command and f"--per-episode {POLICY_RESULTS}" in command
    short = command.replace("--episodes 1000", "--episodes 2")
    short = short.replace(str(POLICY_RESULTS), str(tmp_path / "first.json"))
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    result = subprocess.run(
        ["bash", "-c", short], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
        check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    stored = json.loads((ROOT / POLICY_RESULTS).read_text())
    for policy, records in json.loads((tmp_path / "first.json").read_text()).items():
        _assert_same_episodes(records, stored[policy][:2])
    for policy, records in stored.items():
        if policy == "random":  # one action stream over the run's episodes: only from the start
            continue
        picked = records[137::167]  # 6 episodes, picked by position, not by outcome
        again = [r for p in picked for r in evaluate(policy, 1, p["seed"]).per_episode]
        _assert_same_episodes(again, picked)


def _assert_same_episodes(measured: list[Any], expected: list[Any]) -> None:
    # Deterministic episodes: outcome and length exactly; return and speed to the last digits.
    for m, e in zip(measured, expected, strict=True):
        key = ("seed", "succeeded", "collided", "length")
        assert [m[k] for k in key] == [e[k] for k in key]
        assert m["return"] == pytest.approx(e["return"], rel=1e-6, abs=1e-6)
        assert m["speed"] == pytest.approx(e["speed"], rel=1e-6, abs=1e-9)


def test_readme_learning_curve_command_writes_the_picture(tmp_path):
    out = tmp_path / "curve.png"
    result = subprocess.run(
        [sys.executable, "docs/plot_training.py", "policies/trained", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "python docs/plot_training.py" in README
    assert (ROOT / "docs" / "images" / "ppo_learning_curve.png").is_file()


def test_record_help_shows_each_options_default():
    # README: "`bubblerob COMMAND --help` shows every option with its default".
    pytest.importorskip("rosbags")
    import argparse

    from bubblerob_cli.main import build_parser

    parser = build_parser()
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    record = commands.choices["record"]
    hidden = []
    for action in record._actions:
        help_text = record.formatter_class("record")._get_help_string(action) or ""
        takes_value = action.nargs != 0 and action.option_strings and action.help
        if takes_value and action.default not in (None, argparse.SUPPRESS):
            hidden += [] if "default" in help_text else [action.option_strings[0]]
    assert hidden == []
    shown = " ".join(record.format_help().split())
    assert "seed of the first episode (default 0)" in shown
    assert "step limit per episode (default: the env's time limit)" in shown
