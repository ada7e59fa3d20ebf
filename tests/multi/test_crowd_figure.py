"""docs/make_crowd_figure.py draws README's crowd crossing picture (in-process, tiny)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason="the [multi] extra is not installed")
pytest.importorskip("matplotlib", reason="the figure needs matplotlib (the [dev] extra)")

SCRIPT = Path(__file__).resolve().parents[2] / "docs" / "make_crowd_figure.py"


def test_the_crowd_figure_script_draws_each_policys_crossing_as_a_png(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("make_crowd_figure", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    run = module.crossing("crowd", 3, 100_000, max_steps=40)
    assert sorted(run["paths"]) == ["bubblerob_0", "bubblerob_1", "bubblerob_2"]
    assert all(len(path) >= 2 for path in run["paths"].values())
    out = tmp_path / "crowd.png"
    module.main(
        ["--robots", "2", "--policy", "navigator", "crowd", "--max-steps", "30", "--out", str(out)]
    )
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (SCRIPT.parents[0] / "images" / "crowd_circle.png").is_file()  # README's copy
