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
    set_up = _commands(_section_block("Set up")) + _commands(_section_block("Run the tests"))[:-1]
    assert len(set_up) >= 4
    for command in set_up:
        assert command in ci_lines, f"CI does not run README's {command!r}"
    # in README's order
    positions = [ci_lines.index(command) for command in set_up]
    assert positions == sorted(positions)


def test_readmes_first_install_is_the_torch_free_demo_extra():
    pip_commands = [c for c in _commands(_section_block("Set up")) if c.startswith("pip ")]
    assert pip_commands[0] == 'pip install -e ".[demo]"'
    assert "torch" not in _section_block("Set up").split("\n")[1]
    # CI runs the demo between that install and the first one that brings torch
    ci_lines = [line.strip() for line in CI_SCRIPT.splitlines()]
    demo = next(i for i, line in enumerate(ci_lines) if line.startswith("bubblerob demo"))
    first_torch = next(
        i for i, line in enumerate(ci_lines) if "torch" in line and line[:4] == "pip "
    )
    assert ci_lines.index(pip_commands[0]) < demo < first_torch


def test_ci_ends_with_readmes_test_command():
    test_command = _commands(_section_block("Run the tests"))[-1]
    assert test_command == "python -m pytest"
    ci_commands = [line for line in CI_SCRIPT.splitlines() if line and not line.startswith("#")]
    assert ci_commands[-1] == test_command


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


def test_quickstart_runs(tmp_path):
    quickstart, subprocesses = _code_blocks("python")
    result = _run_python_block(quickstart, tmp_path)
    assert result.returncode == 0, result.stderr
    assert re.search(r"t=\d+\.\d\ds pose=\(", result.stdout)


def test_subprocess_vector_env_example_runs(tmp_path):
    quickstart, subprocesses = _code_blocks("python")
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


def _run_section(heading: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    script = "set -euo pipefail\n" + _section_block(heading)
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
    result = _run_section("Run the demo", tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo").is_dir()
    assert (tmp_path / "demo_output" / "bubblerob_demo_ppo.mp4").stat().st_size > 10_000
    assert "success" in result.stdout


def _markdown_rows(text: str) -> dict[str, list[float]]:
    rows = {}
    for line in text.splitlines():
        cells = [cell.strip().rstrip("%") for cell in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[0] not in ("policy", "---"):
            rows[cells[0]] = [float(cell) for cell in cells[1:]]
    return rows


def test_readme_policy_table_is_reproduced(tmp_path):
    # The README's 100-episode table, re-measured: deterministic episodes, so only last-digit
    # differences (torch's CPU kernels on another machine) are allowed.
    section = README.split("## Policies\n", 1)[1].split("\n## ", 1)[0]
    result = _run_section("Policies", tmp_path)
    assert result.returncode == 0, result.stderr
    expected, measured = _markdown_rows(section), _markdown_rows(result.stdout)
    assert set(measured) == set(expected) == {"reactive", "laser", "ppo", "random"}
    for policy, (episodes, success, collision, speed, length, ret) in expected.items():
        m_episodes, m_success, m_collision, m_speed, m_length, m_ret = measured[policy]
        assert m_episodes == episodes == 100
        assert abs(m_success - success) <= 3 and abs(m_collision - collision) <= 3, policy
        assert abs(m_speed - speed) <= 3 and abs(m_length - length) <= 0.03 * length, policy
        assert abs(m_ret - ret) <= 0.05 * abs(ret) + 5, policy


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
