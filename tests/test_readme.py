"""README's commands are the ones CI runs, and its code runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
CI_SCRIPT = (ROOT / ".ci" / "run").read_text()


def _code_blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.DOTALL)


def _section_block(heading: str) -> str:
    section = README.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)[0]


def _commands(block: str) -> list[str]:
    return [line for line in block.splitlines() if line.strip() and not line.startswith("#")]


def test_ci_runs_readmes_set_up_commands():
    ci_lines = [line.strip() for line in CI_SCRIPT.splitlines()]
    for command in _commands(_section_block("Set up")):
        assert command in ci_lines, f"CI does not run README's {command!r}"


def test_ci_ends_with_readmes_test_command():
    (test_command,) = _commands(_section_block("Run the tests"))
    ci_commands = [line for line in CI_SCRIPT.splitlines() if line and not line.startswith("#")]
    assert ci_commands[-1] == test_command


def test_quickstart_runs():
    (quickstart,) = _code_blocks("python")
    result = subprocess.run(
        [sys.executable, "-c", quickstart],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert re.search(r"t=\d+\.\d\ds pose=\(", result.stdout)


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


def _run_section(heading: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    script = "set -euo pipefail\n" + _section_block(heading)
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    return subprocess.run(
        ["bash", "-c", script], cwd=cwd, env=env, capture_output=True, text=True, timeout=900,
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
    result = _run_section("Run the demo", tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo").is_dir()
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo.mp4").stat().st_size > 10_000
    assert "success" in result.stdout
