"""``bubblerob detect BAG``: the recogniser scored on a bag recorded here, on unseen seeds."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest
from ros_helpers import read_all

from bubblerob_cli import main as cli

SEED = 9100
"""Seeds 9100 and on: the recogniser's priors were chosen on seeds 0-49."""
README = Path(__file__).resolve().parents[2] / "README.md"


def _record(out: Path, *options: str) -> None:
    argv = ["record", "--policy", "random", "--episodes", "2", "--seed", str(SEED)]
    argv += ["--max-steps", "40", "--no-progress", "--out", str(out), *options]
    assert cli.main(argv) == 0


def _readme_commands() -> list[list[str]]:
    """The commands of README's Recognise block, as ``bubblerob`` arguments."""
    section = README.read_text().split("## Recognise\n", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)
    commands = [shlex.split(line) for line in block.splitlines() if line.strip()]
    assert all(command[0] == "bubblerob" for command in commands)
    return [command[1:] for command in commands]


def test_readmes_detect_scores_a_recorded_bag_against_its_re_simulated_truth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    record, detect = _readme_commands()
    assert record[:2] == ["record", "--policy"] and detect[0] == "detect"
    assert f"--seed {SEED}" in " ".join(record)
    monkeypatch.chdir(tmp_path)
    assert cli.main([*record, "--no-progress"]) == 0
    capsys.readouterr()
    assert cli.main(detect) == 0
    report = json.loads(capsys.readouterr().out)
    bag = tmp_path / detect[1]
    messages = read_all(bag)
    images = len(messages["/camera/image_raw"])
    assert report["images"] == images == len(messages["/detections"]) == 82
    assert report["episodes"] == 2
    assert report["images_rendered_differently"] == 0  # re-simulated at the recorded poses
    assert report["obstacles_in_view"] >= 20 and report["objects"] > report["obstacles_in_view"]
    # Issue #28's targets, on seeds nothing was tuned on.
    assert report["precision"] >= 0.95 and report["recall"] >= 0.95
    assert report["class_accuracy"] >= 0.95
    assert report["bearing_error_mean_deg"] <= 2.0
    assert report["min_pixels"] == 50


def test_detect_refuses_what_it_cannot_score_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _record(tmp_path, "--max-steps", "3")  # no camera
    cases = {
        tmp_path / "missing": "no bag at",
        tmp_path / f"bubblerob_random_seed{SEED}": "has no camera: record with the camera on",
    }
    (tmp_path / "empty").mkdir()
    cases[tmp_path / "empty"] = "empty"
    capsys.readouterr()
    for path, said in cases.items():
        assert cli.main(["detect", str(path)]) == 2, path
        err = capsys.readouterr().err
        assert err.startswith("bubblerob detect: ") and said in err, err
        assert err.count("\n") == 1, err
