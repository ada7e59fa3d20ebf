"""Each subcommand runs with only the extra README installs for it (issue #22, item 5).

For each extra, a fresh venv gets the wheel built from this checkout and, of this test's own
environment, only the distributions that ``bubblerob[extra]`` requires (its dependency closure,
linked, so nothing is downloaded). Every subcommand's ``--help`` runs there, one small real call
each, and a subcommand of another extra says in one line which extra to install. An import that
an extra does not declare (``bubblerob map`` needed imageio, which only [dev] brought) fails here.
"""

from __future__ import annotations

import importlib.metadata as metadata
import importlib.util
import json
import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from bubblerob_cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]
SITE = Path(sysconfig.get_paths()["purelib"])

# Subcommands by the extra README installs for them (None: the env alone, no extra).
SUBCOMMANDS = {
    None: ("teleop",),
    "ros": ("record", "info", "replay", "recover", "node", "map", "localize", "detect"),
    "demo": ("evaluate", "demo"),
    "train": ("train",),
}


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _wheel_requirements(wheel: Path) -> list[Requirement]:
    import zipfile

    with zipfile.ZipFile(wheel) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        text = archive.read(name).decode()
    return [
        Requirement(line.split(":", 1)[1])
        for line in text.splitlines()
        if line.startswith("Requires-Dist:")
    ]


def _closure(wheel: Path, extra: str | None) -> set[str]:
    """Distribution names ``bubblerob[extra]`` installs, with their own dependencies."""
    own = _wheel_requirements(wheel)
    extras, found, queue = {extra} if extra else set(), set(), []
    changed = True
    while changed:  # bubblerob's extras name each other: bubblerob[ros] inside [demo]
        changed = False
        for requirement in own:
            if requirement.marker is None or any(
                requirement.marker.evaluate({"extra": e}) for e in extras or {""}
            ):
                if _normal(requirement.name) == "bubblerob":
                    changed |= not requirement.extras <= extras
                    extras |= requirement.extras
                else:
                    queue.append(requirement)
    while queue:
        requirement = queue.pop()
        name = _normal(requirement.name)
        if name in found:
            continue
        found.add(name)
        for inner in metadata.distribution(name).requires or []:
            nested = Requirement(inner)
            wanted = requirement.extras or {""}
            if nested.marker is None or any(nested.marker.evaluate({"extra": e}) for e in wanted):
                queue.append(nested)
    return found


def _link_closure(names: set[str], into: Path) -> None:
    """Link each distribution's top-level files and folders (and its .dist-info) into ``into``."""
    into.mkdir()
    for name in names:
        for file in metadata.distribution(name).files or []:
            top = file.parts[0]
            if top in ("..", "__pycache__") or (into / top).exists():
                continue
            if (SITE / top).exists():
                (into / top).symlink_to(SITE / top)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    spec = importlib.util.spec_from_file_location(
        "install_cost", ROOT / "bench" / "install_cost.py"
    )
    assert spec is not None and spec.loader is not None
    install_cost = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(install_cost)
    return Path(install_cost.build_wheel(tmp_path_factory.mktemp("wheel")))


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """The wheel installed once, shared by the venvs: numba compiles the step kernel only once."""
    target = tmp_path_factory.mktemp("installed")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q",
         "--target", str(target), str(wheel)],
        check=True, capture_output=True, timeout=300,
    )  # fmt: skip
    return target


def _venv(wheel: Path, installed: Path, extra: str | None, home: Path) -> Path:
    """A venv that sees the installed wheel and ``bubblerob[extra]``'s closure, nothing else."""
    prefix = home / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(prefix)], check=True)
    where = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
    site = subprocess.run(
        [str(prefix / "bin" / "python"), "-c", where], check=True, capture_output=True, text=True
    ).stdout.strip()
    closure = home / "closure"
    _link_closure(_closure(wheel, extra), closure)
    for entry in installed.iterdir():
        if entry.name != "bin":
            (closure / entry.name).symlink_to(entry)
    (Path(site) / "zz_closure.pth").write_text(f"import site; site.addsitedir({str(closure)!r})\n")
    return prefix


def _run(
    prefix: Path, *args: str, cwd: Path, timeout: int = 300
) -> subprocess.CompletedProcess[str]:
    """``bubblerob ARGS`` (``python -m bubblerob_cli``), or ``python ...``, in the venv."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{prefix / 'bin'}{os.pathsep}{env['PATH']}"
    command = list(args[1:]) if args[0] == "python" else ["-m", "bubblerob_cli", *args[1:]]
    return subprocess.run(
        [str(prefix / "bin" / "python"), *command],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False,
    )  # fmt: skip


def test_every_subcommand_is_listed_under_an_extra() -> None:
    parser = build_parser()
    (commands,) = [a for a in parser._actions if a.dest == "command"]
    assert sorted(commands.choices) == sorted(c for cs in SUBCOMMANDS.values() for c in cs)


HELP_AND_REFUSALS = """
import contextlib, io, json, sys
from bubblerob_cli.main import main

helped, refused = {}, {}
for command in sys.argv[1].split(","):
    shown = io.StringIO()
    with contextlib.redirect_stdout(shown), contextlib.suppress(SystemExit):
        main([command, "--help"])
    helped[command] = shown.getvalue()
for command in filter(None, sys.argv[2].split(",")):
    try:
        main([command])
    except SystemExit as error:
        refused[command] = str(error.code)
codes = []
for argv in json.loads(sys.argv[3]):
    try:
        codes.append(main(argv))
    except SystemExit as error:
        codes.append(error.code)
print(json.dumps([helped, refused, codes]))
"""


def _help_and_refusals(
    prefix: Path, extra: str | None, cwd: Path, runs: list[list[str]] | None = None
) -> list[int]:
    """Each command of ``extra`` shows its help; one of each extra not installed names it.

    ``runs``: ``bubblerob`` command lines run after, in the same process (one interpreter and one
    import of each module per venv; the venv alone decides what can be imported); their exit codes.
    """
    installed = {extra, None, *{"demo": ("ros",), "train": ("ros", "demo")}.get(str(extra), ())}
    refused = {commands[0]: other for other, commands in SUBCOMMANDS.items()}
    refused = {command: other for command, other in refused.items() if other not in installed}
    ran = _run(
        prefix, "python", "-c", HELP_AND_REFUSALS, ",".join(SUBCOMMANDS[extra]), ",".join(refused),
        json.dumps(runs or []), cwd=cwd,
    )  # fmt: skip
    assert ran.returncode == 0, ran.stderr
    helped, messages, codes = json.loads(ran.stdout.strip().splitlines()[-1])
    for command in SUBCOMMANDS[extra]:
        assert f"usage: bubblerob {command}" in helped[command], (command, ran.stderr)
    assert sorted(messages) == sorted(refused)
    for command, other in refused.items():
        message = messages[command]
        assert "\n" not in message and f"pip install 'bubblerob[{other}]'" in message, message
    for argv, code in zip(runs or [], codes, strict=True):
        assert code == 0, (argv, ran.stderr)
    return list(codes)


def test_the_env_alone(wheel, installed, tmp_path) -> None:
    prefix = _venv(wheel, installed, None, tmp_path)
    code = (
        "import gymnasium as gym, bubblerob_env; "
        "print(gym.make('BubbleRob-v0').reset(seed=0)[0]['laser'].shape)"
    )
    made = _run(prefix, "python", "-c", code, cwd=tmp_path)  # before the CLI imports anything
    assert made.returncode == 0 and "(360,)" in made.stdout, made.stderr
    # backend="warp" without the [warp] extra: one line naming it
    code = (
        "import gymnasium as gym, bubblerob_env\n"
        "try:\n"
        "    gym.make_vec('BubbleRob-v0', 2, vectorization_mode='vector_entry_point', "
        "backend='warp')\n"
        "except ValueError as error:\n"
        "    print(error)"
    )
    refused = _run(prefix, "python", "-c", code, cwd=tmp_path)
    assert refused.stdout.strip() == (
        "backend='warp' needs MuJoCo Warp: pip install 'bubblerob[warp]' "
        "(mujoco-warp and warp-lang)"
    ), refused.stderr
    _help_and_refusals(prefix, None, tmp_path)


def test_ros_commands_with_only_the_ros_extra(wheel, installed, tmp_path) -> None:
    prefix = _venv(wheel, installed, "ros", tmp_path)
    bag = "bags/bubblerob_laser_seed0"
    _help_and_refusals(
        prefix, "ros", tmp_path,
        [["record", "--policy", "laser", "--episodes", "1", "--max-steps", "40", "--no-progress",
          "--out", "bags"],
         ["info", bag], ["replay", bag], ["map", bag, "--out", "m.png"],
         ["localize", bag, "--out", "l.png"]],
    )  # fmt: skip
    assert [p.name for p in (tmp_path / "bags").iterdir()] == ["bubblerob_laser_seed0"]
    assert (tmp_path / "l.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"


def test_demo_and_evaluate_with_only_the_demo_extra(wheel, installed, tmp_path) -> None:
    prefix = _venv(wheel, installed, "demo", tmp_path)
    _help_and_refusals(
        prefix, "demo", tmp_path,
        [["evaluate", "--policy", "laser", "--policy", "ppo", "--episodes", "1",
          "--env-kwargs", '{"max_episode_steps": 30}', "--video", "v.gif"],
         ["demo", "--episodes", "1", "--out", "out"]],
    )  # fmt: skip
    assert (tmp_path / "v.gif").stat().st_size > 1000
    assert (tmp_path / "out" / "bubblerob_demo_ppo.mp4").stat().st_size > 10_000


def test_train_with_only_the_train_extra(wheel, installed, tmp_path) -> None:
    prefix = _venv(wheel, installed, "train", tmp_path)
    _help_and_refusals(
        prefix, "train", tmp_path,
        [["train", "--timesteps", "64", "--n-envs", "1", "--set", "n_steps=32",
          "--set", "batch_size=32", "--eval-freq", "64", "--eval-episodes", "1", "--out", "run",
          "--no-progress"]],
    )  # fmt: skip
    assert (tmp_path / "run" / "model.zip").is_file()
