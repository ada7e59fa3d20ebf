"""What users import is listed in the packages' __all__ (issue #22, item 8)."""

from __future__ import annotations

import importlib

import pytest


@pytest.mark.parametrize(
    ("module", "names"),
    [
        (
            "bubblerob_env",
            [
                "BubbleRobEnv",
                "BubbleRobVectorEnv",
                "EnvSpecs",
                "LaserPooling",
                "ArenaLayout",
                "Obstacle",
                "TopDownView",
                "LaserSpec",
                "OBS_MODES",
            ],
        ),
        ("bubblerob_env.ros", ["replay_bag", "ReplayReport", "ReplayError", "Divergence"]),
        ("policies", ["Policy", "PolicyEnvMismatchError", "load_policy"]),
    ],
)
def test_public_names_are_exported(module, names):
    imported = importlib.import_module(module)
    for name in names:
        assert name in imported.__all__, f"{module}.__all__ lacks {name}"
        assert getattr(imported, name) is not None
