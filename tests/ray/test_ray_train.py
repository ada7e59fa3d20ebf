"""`bubblerob train --ray local --seeds ...`: runs as tasks, best models validated, best named."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from ray_helpers import as_json, bubblerob_in_netns, need_netns

from bubblerob_cli.main import main as bubblerob
from bubblerob_cli.ray.sweep import VALIDATION_SEED
from policies.evaluation import evaluate

TINY = [
    "train", "--timesteps", "128", "--eval-freq", "64", "--eval-episodes", "1", "--n-envs", "1",
    "--set", "n_steps=64", "--set", "batch_size=64", "--no-progress",
]  # fmt: skip


def test_sweep_trains_each_seed_in_its_folder_and_names_the_best(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3", reason="the [train] extra is not installed")
    need_netns()
    argv = [*TINY, "--ray", "local", "--seeds", "3,5", "--validation-episodes", "2"]
    done = bubblerob_in_netns([*argv, "--out", str(tmp_path)], timeout_s=400)
    assert done.returncode == 0, done.stderr[-4000:]
    sweep = json.loads((tmp_path / "sweep.json").read_text())
    assert [run["seed"] for run in sweep["runs"]] == [3, 5]
    rows = []
    for run in sweep["runs"]:
        folder = Path(run["folder"])
        assert folder == tmp_path / f"seed_{run['seed']}"
        config = yaml.safe_load((folder / "config.yml").read_text())["BubbleRob-v0"]
        assert config["seed"] == run["seed"]
        # The oracle, without Ray: the model in the env it trained in (the run's env_kwargs).
        serial = evaluate(run["policy"], 2, VALIDATION_SEED, env_kwargs=config["env_kwargs"])
        expected = as_json(serial)  # as sweep.json holds it
        assert {k: run[k] for k in expected} == expected
        rows.append(serial)
    best = max(rows, key=lambda r: (r.success_rate, r.mean_return))
    assert sweep["best"]["model"] == best.policy
    assert f"best run: seed {sweep['best']['seed']} ({best.policy})" in done.stdout


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--seeds", "0,1"], "--ray and --seeds go together"),
        (["--ray", "local"], "--ray and --seeds go together"),
        (["--ray", "local", "--seeds", "1,1"], "--seeds must be distinct ints"),
        (["--ray", "local", "--seeds", "1,x"], "--seeds must be ints separated by commas"),
        (["--ray", "local", "--seeds", "1", "--validation-episodes", "0"], "--validation-episodes"),
    ],
)
def test_sweep_usage_errors_are_one_line(
    extra: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("stable_baselines3", reason="the [train] extra is not installed")
    with pytest.raises(SystemExit) as exited:
        code = bubblerob([*TINY, *extra, "--out", str(tmp_path)])
        raise SystemExit(code)
    assert exited.value.code == 2
    assert message in capsys.readouterr().err
