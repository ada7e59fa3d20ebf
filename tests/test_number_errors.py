"""Where a config value must be a number, anything else is one line naming it and what is allowed.

Not Python's ``could not convert string to float``: the residual scale, rl-zoo's ``lin_`` schedules
and the obstacle curriculum's numbers, in the library and through ``bubblerob train``.
"""

from __future__ import annotations

import re

import pytest
from cli_usage import run

from policies.residual import check_scale
from train.checks import TrainArgumentError, check_hyperparams, schedule_start

RESIDUAL = "policies.residual.ResidualOnLaser"
CURRICULUM = "train.callbacks.ObstacleCurriculum"


@pytest.mark.parametrize("scale", ["abc", None, True, [0.5], "nan", float("inf")])
def test_a_residual_scale_that_is_no_number_is_named(scale: object) -> None:
    with pytest.raises(ValueError, match=re.escape(f"must be in (0, 2], got {scale!r}")):
        check_scale(scale)


def test_a_residual_scale_may_be_a_number_or_its_text() -> None:
    assert check_scale(0.25) == 0.25 and check_scale("1.5") == 1.5 and check_scale(2) == 2.0


@pytest.mark.parametrize("text", ["lin_abc", "lin_", "lin_-3e-4", "lin_inf", "fast"])
def test_a_schedule_that_is_no_number_is_named(text: str) -> None:
    allowed = "must be a number > 0 or a schedule such as 'lin_3e-4'"
    with pytest.raises(TrainArgumentError, match=re.escape(f"{allowed}, got {text!r}")):
        check_hyperparams("ppo", {"learning_rate": text})
    assert schedule_start("clip_range", "lin_0.2") == 0.2


def test_curriculum_numbers_are_checked_with_the_hyperparameters() -> None:
    pytest.importorskip("stable_baselines3")
    bad = {"callback": [{CURRICULUM: {"ramp_fraction": "abc"}}]}
    with pytest.raises(ValueError, match=re.escape("a number in (0, 1], got 'abc'")):
        check_hyperparams("ppo", bad)
    with pytest.raises(ValueError, match=re.escape("two ints [low, high]")):
        check_hyperparams("ppo", {"callback": [{CURRICULUM: {"start": ["a", 2]}}]})


@pytest.mark.parametrize(
    ("setting", "line"),
    [
        (
            f"env_wrapper=[{{{RESIDUAL}: {{scale: abc}}}}]",
            "bubblerob train: residual scale must be in (0, 2], got 'abc'",
        ),
        (
            "learning_rate=lin_abc",
            "bubblerob train: hyperparameter learning_rate must be a number > 0 or a schedule "
            "such as 'lin_3e-4', got 'lin_abc'",
        ),
    ],
)
def test_train_refuses_them_in_one_line_before_training(
    setting: str, line: str, tmp_path: object, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("stable_baselines3")
    result = run(["train", "--out", str(tmp_path), "--set", setting], capsys)
    assert (result.code, result.one_line()) == (2, line)


@pytest.mark.parametrize("pool", ["abc", 0, 2.5, None])
def test_a_laser_pooling_that_is_no_int_is_named(pool: object) -> None:
    spec = [{"bubblerob_env.wrappers.LaserPooling": {"pool": pool}}]
    with pytest.raises(ValueError, match=re.escape(f"pool must be an int >= 1, got {pool!r}")):
        check_hyperparams("ppo", {"env_wrapper": spec})
