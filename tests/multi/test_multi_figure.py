"""docs/make_multi_figure.py draws README's several-robots picture (in-process, tiny)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason="the [multi] extra is not installed")
pytest.importorskip("matplotlib", reason="the figure needs matplotlib (the [dev] extra)")

SCRIPT = Path(__file__).resolve().parents[2] / "docs" / "make_multi_figure.py"


def test_the_figure_script_draws_the_world_and_a_camera_as_a_png(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("make_multi_figure", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.main(tmp_path / "several.png", size=40)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (SCRIPT.parents[0] / "images" / "several_robots.png").is_file()  # README's copy
