"""The layers of the ROS layer import only downwards (docs/ARCHITECTURE.md).

Walks every module's imports (top-level and inside functions) with ``ast``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "bubblerob_env"

FORBIDDEN = {
    "core": ("bubblerob_env.ros",),
    "ros/messages": (
        "bubblerob_env.ros.fastpath", "bubblerob_env.ros.bags", "bubblerob_env.ros.readback",
        "bubblerob_env.ros.live", "bubblerob_env.ros.recorder", "bubblerob_env.ros.episodes",
    ),
    "ros/fastpath": (
        "bubblerob_env.ros.bags", "bubblerob_env.ros.live", "bubblerob_env.ros.readback",
    ),
    "ros/bags": ("bubblerob_env.ros.live", "bubblerob_env.ros.readback"),
}  # fmt: skip


def _modules(layer: str) -> list[Path]:
    if layer == "core":
        return sorted(PACKAGE.glob("*.py"))
    return sorted((PACKAGE / layer).rglob("*.py"))


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layer_imports_nothing_above_it(layer):
    modules = _modules(layer)
    assert modules, layer
    wrong = [
        f"{path.relative_to(PACKAGE)} imports {name}"
        for path in modules
        for name in sorted(_imports(path))
        if any(name == bad or name.startswith(bad + ".") for bad in FORBIDDEN[layer])
    ]
    assert not wrong, wrong


def test_no_module_uses_relative_imports():
    # The walk above reads absolute imports only: keep it that way.
    relative = [
        str(path.relative_to(PACKAGE))
        for path in PACKAGE.rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.ImportFrom) and node.level > 0
    ]
    assert not relative, relative
