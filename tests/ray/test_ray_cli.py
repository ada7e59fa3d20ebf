"""``bubblerob evaluate --ray``: one line for a bad address, Ctrl-C; without Ray, one line.

Its table equals the serial command's: test_ray_local.py runs it on that module's cluster.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest
from ray_helpers import bubblerob_in_netns, in_netns, need_netns

EVALUATE = [
    "evaluate", "--policy", "reactive", "--policy", "laser", "--policy", "reactive",
    "--episodes", "4", "--seed", "7",
    "--env-kwargs", '{"max_episode_steps": 100}',
]  # fmt: skip


@pytest.mark.parametrize(
    ("address", "code", "message"),
    [
        ("nonsense", 2, "--ray 'nonsense' is not an address: use 'local', 'auto', HOST:PORT"),
        ("", 2, "--ray needs an address"),
        ("127.0.0.1:1", 1, "--ray 127.0.0.1:1: no Ray cluster answers there"),
        ("auto", 1, "--ray auto: Could not find any running Ray instance"),
    ],
)
def test_bad_addresses_are_one_line(address: str, code: int, message: str) -> None:
    need_netns()
    done = bubblerob_in_netns([*EVALUATE[:3], "--episodes", "1", "--ray", address], timeout_s=60)
    assert done.returncode == code
    assert done.stderr.strip().splitlines()[-1].startswith(f"bubblerob evaluate: {message}")
    assert "Traceback" not in done.stderr


def test_record_refuses_an_existing_bag_before_starting_a_cluster(tmp_path: Path) -> None:
    need_netns()
    (tmp_path / "bubblerob_reactive_seed4-4").mkdir()  # the bag of the one chunk: seeds 4..4
    argv = ["record", "--policy", "reactive", "--episodes", "1", "--seed", "4", "--ray", "local"]
    start = time.monotonic()
    done = bubblerob_in_netns([*argv, "--out", str(tmp_path)], timeout_s=60)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == (
        f"bubblerob record: bag {tmp_path}/bubblerob_reactive_seed4-4 already exists; "
        "pass --overwrite to replace it"
    )
    assert time.monotonic() - start < 10, "a cluster was started first"


HIDE_RAY = """
import sys
from importlib import metadata
real = metadata.distribution
def distribution(name):
    if name == "ray":  # the package's metadata says that Ray is not installed
        raise metadata.PackageNotFoundError(name)
    return real(name)
metadata.distribution = distribution
from bubblerob_cli.main import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize(
    "command",
    [
        ["evaluate", "--policy", "laser", "--episodes", "1"],
        ["record", "--policy", "laser", "--out", "bags"],
        ["train", "--timesteps", "64", "--seeds", "0,1"],
    ],
)
def test_without_ray_the_extra_is_named_in_one_line(command: list[str], tmp_path: Path) -> None:
    need_netns()  # were the check to fail, Ray would start: in a namespace all the same
    if command[0] == "train":
        pytest.importorskip("stable_baselines3", reason="the [train] extra is not installed")
    argv = [sys.executable, "-c", HIDE_RAY, *command, "--ray", "local"]
    done = in_netns(argv, timeout_s=60, cwd=tmp_path)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line == (
        f"bubblerob {command[0]} --ray needs the [ray] extra: pip install 'bubblerob[ray]' "
        "(missing: ray)"
    )


def test_readmes_ray_commands_parse() -> None:
    """README's "Past one machine" commands are ones the CLI takes (smaller ones run above)."""
    import shlex

    from bubblerob_cli.main import build_parser

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Past one machine\n", 1)[1].split("\n## ", 1)[0]
    commands = [line for line in section.splitlines() if line.startswith("bubblerob ")]
    assert [shlex.split(c)[1] for c in commands] == ["evaluate", "record", "train"]
    for command in commands:
        args = build_parser().parse_args(shlex.split(command)[1:])
        assert args.ray == "local", command


def test_ctrl_c_stops_the_run_in_one_line(tmp_path: Path) -> None:
    need_netns()
    import signal
    import subprocess

    argv = [*EVALUATE[:5], "--episodes", "100", "--ray", "local"]
    script = "ip link set lo up && exec " + " ".join(
        [sys.executable, "-m", "bubblerob_cli", *argv]
    )
    stderr = tmp_path / "stderr"
    with stderr.open("w") as sink:
        run = subprocess.Popen(["unshare", "-n", "bash", "-c", script], stderr=sink, text=True)
        try:
            deadline = time.monotonic() + 120
            while "/200 [" not in stderr.read_text() and time.monotonic() < deadline:
                time.sleep(0.2)  # until the cluster is up and the bar shows
            assert "/200 [" in stderr.read_text(), stderr.read_text()[-2000:]
            run.send_signal(signal.SIGINT)
            assert run.wait(timeout=60) == 130
        finally:
            run.kill()
    lines = stderr.read_text().strip().splitlines()
    assert lines[-1] == "bubblerob evaluate: stopped; the cluster's tasks are cancelled"
    assert "Traceback" not in stderr.read_text()
