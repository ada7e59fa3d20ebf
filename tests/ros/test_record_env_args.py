"""``bubblerob record --env ID --env-kwargs JSON`` (issue #22, item 7): a non-default env's bag."""

from __future__ import annotations

import json

import pytest

from bubblerob_cli import main as cli


def test_record_a_non_default_env_and_replay_it(tmp_path, capsys):
    kwargs = json.dumps({"arena_size": 3.0, "laser_num_rays": 90, "action_type": "twist"})
    argv = ["record", "--policy", "laser", "--episodes", "1", "--seed", "3", "--max-steps", "8"]
    argv += ["--env", "BubbleRob-v0", "--env-kwargs", kwargs, "--no-progress"]
    assert cli.main([*argv, "--out", str(tmp_path)]) == 0
    bag = tmp_path / "bubblerob_laser_seed3"
    # Replay re-creates the env from the bag's metadata: a 90-ray scan in a 3 m arena only
    # matches if the bag says which env it came from.
    assert cli.main(["replay", str(bag)]) == 0


def test_record_refuses_bad_env_kwargs_in_one_line(tmp_path, capsys):
    argv = ["record", "--policy", "laser", "--env-kwargs", '{"arena_size": -1}']
    with pytest.raises(SystemExit) as exited:
        cli.main([*argv, "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert exited.value.code == 2 and len(err.splitlines()) == 1 and "arena_size" in err
    assert not any(tmp_path.iterdir())
