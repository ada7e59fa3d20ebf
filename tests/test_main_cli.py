"""The ``bubblerob`` command: --version, --help with defaults and examples, missing extras."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from bubblerob_cli.main import EXAMPLES, build_parser
from bubblerob_env.extras import missing_requirements

ROOT = Path(__file__).resolve().parents[1]
SUBCOMMANDS = ("demo", "evaluate", "train", "record", "info", "replay", "node")


def _bubblerob(*args: str, code: str = "", timeout: int = 120) -> subprocess.CompletedProcess[str]:
    script = (
        f"import sys\n{code}\nfrom bubblerob_cli.main import main\nsys.exit(main(sys.argv[1:]))"
    )
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        cwd=ROOT,
    )


def test_version():
    result = _bubblerob("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"bubblerob {metadata.version('bubblerob')}"


def test_every_subcommand_is_listed_with_help_defaults_and_an_example():
    parser = build_parser()
    choices = parser._subparsers._group_actions[0].choices  # type: ignore[union-attr]
    assert set(SUBCOMMANDS) <= set(choices)
    for name in SUBCOMMANDS:
        text = choices[name].format_help()
        assert "example:" in text and EXAMPLES[name] in text, name
    demo = choices["demo"].format_help()
    assert "(default: 3)" in demo and "(default: ppo)" in demo


@pytest.mark.parametrize(
    ("command", "extra", "hidden"),
    [
        (["demo"], "demo", "onnxruntime"),
        (["evaluate", "--policy", "laser"], "demo", "tqdm"),
        (["train", "--timesteps", "64"], "train", "stable-baselines3"),
        (["record", "--policy", "laser", "--out", "bags"], "ros", "rosbags"),
    ],
)
def test_a_missing_extra_is_named_in_one_line(command, extra, hidden):
    # The package's metadata says that the requirement is not installed.
    hide = (
        "from importlib import metadata\n"
        "real = metadata.distribution\n"
        "def distribution(name):\n"
        f"    if name == {hidden!r}:\n"
        "        raise metadata.PackageNotFoundError(name)\n"
        "    return real(name)\n"
        "metadata.distribution = distribution\n"
    )
    result = _bubblerob(*command, code=hide)
    assert result.returncode != 0
    assert "Traceback" not in result.stderr
    (line,) = result.stderr.strip().splitlines()
    assert line == (
        f"bubblerob {command[0]} needs the [{extra}] extra: pip install 'bubblerob[{extra}]' "
        f"(missing: {hidden})"
    )


def test_this_environment_has_every_extra():
    for extra in ("ros", "demo", "train", "dev"):
        assert missing_requirements(extra) == [], extra


def test_python_m_train_help_shows_defaults_and_example():
    result = subprocess.run(
        [sys.executable, "-m", "train", "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0
    assert "(default: dummy)" in result.stdout and "example:" in result.stdout


def test_evaluate_video_names_its_policy(tmp_path):
    video = tmp_path / "reactive.gif"
    result = _bubblerob(
        "evaluate",
        "--policy",
        "laser",
        "--policy",
        "reactive",
        "--episodes",
        "1",
        "--env-kwargs",
        '{"max_episode_steps": 20}',
        "--video",
        str(video),
        "--video-policy",
        "reactive",
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert f"wrote {video}: policy reactive, seed 1000, 21 frames" in result.stdout
    assert "video reactive -> reactive.gif" in result.stderr  # its progress bar
    import imageio.v3 as iio

    assert iio.imread(video, index=None).shape[0] == 21
