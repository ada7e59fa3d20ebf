"""The wheel: it holds every file the commands read, and its commands run from a fresh venv.

The wheel is built from this checkout and installed with ``--no-deps`` into a new venv outside
the repository. Its dependencies come from this test's own environment through a ``.pth`` line
(a plain path: that site-packages' own ``.pth`` files, among them the editable install of this
checkout, are not run), so nothing is downloaded. Every ``bubblerob``, ``policies`` and ``train``
module the commands import is asserted to come from the fresh venv, not from the checkout; the
demo runs with torch and SB3 made unimportable.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("bubblerob_cli", "bubblerob_env", "policies", "train")
_BLOCK_TORCH = (
    "import os, sys; os.environ.get('BUBBLEROB_TEST_NO_TORCH') and "
    "sys.modules.update(torch=None, stable_baselines3=None)\n"
)


def _tracked_data_files() -> list[str]:
    listed = subprocess.run(
        ["git", "ls-files", *PACKAGES], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    return [path for path in listed if not path.endswith(".py") and "__pycache__" not in path]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    # Built from a clean copy of the sources (a stale build/ folder in the tree could add files
    # that no longer exist), the way bench/install_cost.py builds the wheel it installs.
    spec = importlib.util.spec_from_file_location(
        "bench_install_cost", ROOT / "bench" / "install_cost.py"
    )
    assert spec is not None and spec.loader is not None
    install_cost = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(install_cost)
    return Path(install_cost.build_wheel(tmp_path_factory.mktemp("wheel")))


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory) -> Path:
    home = tmp_path_factory.mktemp("venv")
    assert ROOT not in home.parents
    prefix = home / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(prefix)], check=True)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(prefix / "bin" / "python"),
            "install",
            "--no-deps",
            "--no-index",
            "-q",
            str(wheel),
        ],
        check=True,
        capture_output=True,
        text=True,
        timeout=300,
    )
    site = Path(
        subprocess.run(
            [
                str(prefix / "bin" / "python"),
                "-c",
                "import sysconfig; print(sysconfig.get_paths()['purelib'])",
            ],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    (site / "zz_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    (site / "zz_test_no_torch.pth").write_text(_BLOCK_TORCH)
    return prefix


def _run(venv: Path, args: list[str], cwd: Path, no_torch: bool = False, timeout: int = 600):
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH",)}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env['PATH']}"
    env["VIRTUAL_ENV"] = str(venv)
    if no_torch:
        env["BUBBLEROB_TEST_NO_TORCH"] = "1"
    return subprocess.run(
        args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False
    )


def test_wheel_holds_every_data_file_of_the_packages(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    data = _tracked_data_files()
    for required in (
        "train/hyperparams/ppo.yml",
        "policies/trained/ppo_bubblerob_v0.onnx",
        "policies/trained/ppo_bubblerob_v0.zip",
        "bubblerob_env/ros/launch/bubblerob.launch",
    ):
        assert required in data, required
    assert [path for path in data if path.startswith("bubblerob_env/assets/")]  # the MJCF
    missing = [path for path in data if path not in names]
    assert not missing, f"not in the wheel: {missing}"
    assert not [name for name in names if name.startswith("tests/")]


def test_installed_modules_come_from_the_wheel_not_the_checkout(venv, tmp_path):
    code = (
        "import bubblerob_env, policies, train, policies.export_onnx, bubblerob_env.ros, "
        "bubblerob_cli.main; import sys; "
        "print('\\n'.join(m.__file__ for n, m in list(sys.modules.items()) "
        "if n.split('.')[0] in ('bubblerob_cli', 'bubblerob_env', 'policies', 'train') "
        "and getattr(m, '__file__', None)))"
    )
    result = _run(venv, ["python", "-c", code], tmp_path)
    assert result.returncode == 0, result.stderr
    files = result.stdout.split()
    assert len(files) > 10
    assert all(Path(path).is_relative_to(venv) for path in files), files


def test_cli_version_and_help_from_the_wheel(venv, tmp_path):
    version = _run(venv, ["bubblerob", "--version"], tmp_path)
    assert version.returncode == 0 and version.stdout.startswith("bubblerob "), version.stderr
    launch = _run(venv, ["bubblerob", "node", "--launch-dir"], tmp_path)
    assert launch.returncode == 0, launch.stderr
    launch_dir = Path(launch.stdout.strip().split(os.pathsep)[0])
    assert launch_dir.is_relative_to(venv), launch_dir
    assert list(launch_dir.rglob("bubblerob.launch"))


def test_demo_runs_from_the_wheel_without_torch(venv, tmp_path):
    result = _run(
        venv, ["bubblerob", "demo", "--episodes", "1", "--out", "out"], tmp_path, no_torch=True
    )
    assert result.returncode == 0, result.stderr
    assert "success" in result.stdout
    assert (tmp_path / "out" / "bubblerob_demo_ppo").is_dir()
    assert (tmp_path / "out" / "bubblerob_demo_ppo.mp4").stat().st_size > 10_000
    # and the same interpreter really cannot import torch
    check = _run(venv, ["python", "-c", "import torch"], tmp_path, no_torch=True)
    assert check.returncode != 0 and "torch" in check.stderr


def test_short_training_runs_from_the_wheel(venv, tmp_path):
    result = _run(
        venv,
        [
            "bubblerob",
            "train",
            "--timesteps",
            "128",
            "--n-envs",
            "2",
            "--set",
            "n_steps=32",
            "--set",
            "batch_size=32",
            "--eval-freq",
            "64",
            "--eval-episodes",
            "1",
            "--out",
            "run",
            "--no-progress",
        ],
        tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "run" / "model.zip").is_file()
    assert (tmp_path / "run" / "model_vecnormalize.pkl").is_file()
