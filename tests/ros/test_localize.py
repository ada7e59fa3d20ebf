"""``bubblerob localize BAG`` (issue #27 item 3): README's commands on a bag they record.

README's Localise block (run command by command through ``main``) records two 30 s episodes of
the laser policy with drifting odometry (``odometry_noise`` 0.1) on seeds the filter was not tuned
on, then localises them from the bag, tracking and globally. The figures it prints are checked
against issue #27's targets: raw odometry off by >= 0.2 m at the end, mean errors after
convergence <= 0.05 m and 0.05 rad, global localisation converged within 10 s. Bad input is one
line and exit 2.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from bubblerob_cli.main import main
from bubblerob_env.localisation.picture import ESTIMATE, ODOMETRY, TRUTH

ROOT = Path(__file__).resolve().parents[2]


def _localise_block() -> str:
    section = (ROOT / "README.md").read_text().split("## Localise\n", 1)[1].split("\n## ", 1)[0]
    (block,) = [
        b
        for b in re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)
        if "bubblerob localize" in b
    ]
    return block


def _read_png_rgb(path: Path) -> np.ndarray:
    import zlib

    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    chunks, at = b"", 8
    while at < len(data):
        length = int.from_bytes(data[at : at + 4], "big")
        if data[at + 4 : at + 8] == b"IDAT":
            chunks += data[at + 8 : at + 8 + length]
        at += 12 + length
    rows = np.frombuffer(zlib.decompress(chunks), np.uint8).reshape(height, 1 + 3 * width)
    assert not rows[:, 0].any()  # filter type 0 on every row, as write_png writes them
    return rows[:, 1:].reshape(height, width, 3)


@pytest.fixture(scope="module")
def readme_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict], str]:
    """README's commands, each through ``bubblerob``'s ``main`` in this process (no start-up)."""
    cwd = tmp_path_factory.mktemp("localize")
    printed = io.StringIO()
    before = Path.cwd()
    os.chdir(cwd)
    try:
        for line in _localise_block().splitlines():
            command = shlex.split(line)
            assert command[0] == "bubblerob", line
            with contextlib.redirect_stdout(printed):
                assert main(command[1:]) == 0, line
    finally:
        os.chdir(before)
    stdout = printed.getvalue()
    reports = [json.loads(line) for line in stdout.splitlines() if line.startswith("{")]
    return cwd, reports, stdout


def test_tracking_from_the_bag_meets_the_targets(readme_run):
    _, reports, _ = readme_run
    (tracking,) = [r for r in reports if r["mode"] == "tracking"]
    assert tracking["episodes"] == 2 and tracking["truth"] == "/base_pose_ground_truth"
    for episode in tracking["per_episode"]:
        assert episode["odometry_error_final_m"] >= 0.2, episode
        assert episode["converged_after_s"] is not None, episode
        assert episode["position_error_mean_m"] <= 0.05, episode
        assert episode["yaw_error_mean_rad"] <= 0.05, episode
    assert tracking["position_error_mean_m"] <= 0.05 and tracking["yaw_error_mean_rad"] <= 0.05


def test_global_localisation_from_the_bag_meets_the_targets(readme_run):
    cwd, _, stdout = readme_run
    # The README's global run prints text: its summary line.
    assert "2 episode(s), global; truth: /base_pose_ground_truth" in stdout
    mean = re.search(
        r"^mean: position ([\d.]+) cm, yaw ([\d.]+) mrad after convergence; converged within "
        r"10 s in (\d+)%",
        stdout,
        flags=re.MULTILINE,
    )
    assert mean is not None, stdout
    centimetres, milliradians, percent = (float(g) for g in mean.groups())
    assert percent >= 90 and centimetres <= 5.0 and milliradians <= 50.0, stdout
    # The picture: the map with the three paths on it.
    (out,) = re.findall(r"^wrote (\S+\.png)", stdout, flags=re.MULTILINE)
    pixels = _read_png_rgb(cwd / out).reshape(-1, 3)
    for colour in (TRUTH, ODOMETRY, ESTIMATE, (0, 0, 0), (255, 255, 255)):
        assert (pixels == colour).all(axis=1).sum() > 100, colour


def test_a_bag_without_ground_truth_is_scored_against_its_odometry(tmp_path, capsys):
    # Without odometry_noise /odom is the truth: the filter is scored against it, nothing drifts.
    bags = tmp_path / "bags"
    assert main(["record", "--policy", "laser", "--max-steps", "60", "--format", "ros1",
                 "--no-progress", "--out", str(bags)]) == 0  # fmt: skip
    capsys.readouterr()
    (bag,) = bags.glob("*.bag")
    assert main(["localize", str(bag), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["truth"] == "/odom" and report["odometry_error_final_m"] == 0.0
    assert report["position_error_mean_m"] <= 0.05
    assert (tmp_path / "bags" / f"{bag.name}.localize.png").is_file()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["no_such_bag"], "no bag at no_such_bag"),
        (["BAG", "--out", "."], "is a directory"),
        (["BAG", "--out", "x.jpg"], "name a .png file"),
        (["BAG", "--seed", "-1"], "--seed must be an int from 0 to"),
        (["NOT_A_BAG.mcap"], "not an MCAP file"),
        (["BAG"], "BAG"),  # an empty folder: not a bag
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys, args, message):
    (tmp_path / "BAG").mkdir()
    (tmp_path / "NOT_A_BAG.mcap").write_bytes(b"hello")
    monkeypatch.chdir(tmp_path)
    assert main(["localize", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert err.startswith("bubblerob localize: ")


@pytest.mark.parametrize("distro", ["noetic", "humble", "jazzy"])
@pytest.mark.parametrize("count", [0, 1, 5])
def test_particle_cloud_bytes_are_rosbags_serialisation(distro, count):
    # The live node packs /particlecloud with NumPy: the bytes rosbags writes for the same poses.
    from bubblerob_env.ros.live import amcl_messages
    from bubblerob_env.ros.messages.distros import serialize, typestore

    particles = np.random.default_rng(count).uniform(-2.0, 2.0, (count, 3))
    for frame in ("map", "robot2/map", "m"):  # frame lengths that move CDR's alignment
        got = amcl_messages.particle_cloud(distro, 1_795_630_734_076_000_000, frame, particles)
        types = typestore(distro).types
        header = amcl_messages._header(distro, 1_795_630_734_076_000_000, frame)
        poses = [amcl_messages._pose(types, tuple(p)) for p in particles]
        message = types[amcl_messages.PARTICLE_CLOUD](header=header, poses=poses)
        assert got == serialize(distro, message, amcl_messages.PARTICLE_CLOUD), frame


@pytest.mark.parametrize("distro", ["noetic", "jazzy"])
def test_initial_pose_round_trip_and_refusals(distro):
    from bubblerob_env.ros.live import amcl_messages as am

    covariance = np.diag([0.04, 0.09, 0.0, 0.0, 0.0, 0.01])
    raw = am.amcl_pose(
        distro, 10**18, "map", (1.0, -0.5, 2.0), covariance[np.ix_([0, 1, 5], [0, 1, 5])]
    )
    pose, std = am.decode_initial_pose(distro, raw, "map")
    np.testing.assert_allclose(pose, (1.0, -0.5, 2.0), atol=1e-12)
    np.testing.assert_allclose(std, (0.2, 0.3, 0.1), atol=1e-12)
    for bad, reason in [
        (raw[:9], "undecodable"),
        (am.amcl_pose(distro, 10**18, "odom", (0, 0, 0), np.eye(3)), "wrong frame"),
        (am.amcl_pose(distro, 10**18, "map", (math.nan, 0, 0), np.eye(3)), "non-finite"),
        (am.amcl_pose(distro, 10**18, "map", (0, 0, 0), -np.eye(3)), "negative variance"),
    ]:
        with pytest.raises(am.InitialPoseError) as caught:
            am.decode_initial_pose(distro, bad, "map")
        assert caught.value.reason == reason
