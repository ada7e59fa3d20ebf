"""Install time and venv size of ``bubblerob[demo]`` and ``bubblerob[train]`` in fresh venvs.

    python bench/install_cost.py [demo|train ...]

Builds the wheel from this checkout, then for each extra makes a new venv in a temporary folder
and times ``pip install --no-cache-dir <wheel>[extra]`` (every dependency downloaded, none from
pip's cache). For ``train``, torch is pinned to the CPU build pip finds (``--torch``, default
``torch==2.13.0``: a local CPU wheel on the project's machines; elsewhere install torch first from
PyTorch's CPU index, as README says). Prints one Markdown row per extra.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _size_mb(path: Path) -> float:
    return (
        sum(f.stat().st_size for f in path.rglob("*") if f.is_file() and not f.is_symlink()) / 1e6
    )


def build_wheel(out: Path) -> Path:
    source = out / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, source / name)
    for package in ("bubblerob_cli", "bubblerob_env", "policies", "train"):
        shutil.copytree(
            ROOT / package, source / package, ignore=shutil.ignore_patterns("__pycache__")
        )
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(out),
            str(source),
        ],
        check=True,
        timeout=300,
    )
    (wheel,) = out.glob("bubblerob-*.whl")
    return wheel


def measure(wheel: Path, extra: str, torch: str, work: Path) -> tuple[float, float, int]:
    venv = work / f"venv-{extra}"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "--no-cache-dir", "-q"]
    requirements = [f"{wheel}[{extra}]"] + ([torch] if extra == "train" else [])
    start = time.perf_counter()
    subprocess.run(pip + requirements, check=True)
    seconds = time.perf_counter() - start
    listed = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "list", "--format=freeze"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    has_torch = any(line.startswith("torch==") for line in listed)
    if extra == "demo":
        assert not has_torch, "torch in [demo]"
    return seconds, _size_mb(venv), len(listed)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("extras", nargs="*", default=["demo", "train"])
    parser.add_argument("--torch", default="torch==2.13.0", help="torch requirement for [train]")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        wheel = build_wheel(work)
        print("| install | time (s) | venv size (MB) | packages |")
        print("|---|---|---|---|")
        for extra in args.extras:
            seconds, size, count = measure(wheel, extra, args.torch, work)
            print(f"| `bubblerob[{extra}]` | {seconds:.0f} | {size:.0f} | {count} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
