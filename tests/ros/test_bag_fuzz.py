"""Byte flips and truncations of every bag format through info, replay, recover and map.

The property (issue #23): each command gives a correct result or one line and a non-zero exit;
never a traceback, a hang or a wrong answer with exit 0. ``recover`` never changes the original,
and what it writes reads back as a finished bag whose episodes are the original's first ones.
Formats with checksums (MCAP's CRCs, bz2's and LZ4's) must also never list a wrong episode; ROS 1
uncompressed and SQLite carry none, so a flipped byte in a message there can read as another
value (docs/RELIABILITY.md), and only the episode count is held.

CI runs a fixed, derandomised budget per format (``BUBBLEROB_FUZZ_SCALE`` multiplies it, with
random examples: ``bench/fuzz.py``).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ros_helpers import FORMAT_CASES

from bubblerob_env.ros.readback.layout import storage_file
from bubblerob_env.ros.readback.summary import read_summary

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: cli_usage
from cli_usage import run  # noqa: E402

pytest.importorskip("policies")

SCALE = int(os.environ.get("BUBBLEROB_FUZZ_SCALE", "1"))
EPISODES = 2
CHECKSUMMED = {("mcap", "zstd"), ("mcap", "none"), ("ros1", "bz2"), ("ros1", "lz4")}


@pytest.fixture(scope="module")
def originals(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, str], Path]:
    """Two 8-step episodes in every format, with 16-ray scans: small bags, quick commands."""
    import gymnasium as gym
    from ros_helpers import drive

    from bubblerob_env.ros import RosBagRecorder

    root = tmp_path_factory.mktemp("originals")
    made = {}
    for fmt, compression in FORMAT_CASES:
        env = gym.make("BubbleRob-v0", max_episode_steps=8, laser_num_rays=16)
        with RosBagRecorder(
            env, root / f"{fmt}_{compression}", format=fmt, compression=compression
        ) as recorder:
            drive(recorder, EPISODES, 8)
        made[(fmt, compression)] = recorder.bag_paths[0]
    return made


def _digest(path: Path) -> str:
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    return hashlib.sha256(b"".join(p.name.encode() + p.read_bytes() for p in files)).hexdigest()


def _damaged(
    original: Path, where: Path, cut: float | None, flips: list[tuple[float, int]]
) -> Path:
    """A copy of ``original`` cut to ``cut`` of its size, or with bytes XORed at fractions."""
    bag = where / original.name
    (shutil.copytree if original.is_dir() else shutil.copyfile)(original, bag)
    file = storage_file(bag)
    data = bytearray(file.read_bytes())
    if cut is not None:
        data = data[: int(len(data) * cut)]
    for fraction, mask in flips:
        data[min(int(len(data) * fraction), len(data) - 1)] ^= mask
    file.write_bytes(bytes(data))
    return bag


def _check_commands(bag: Path, original: Path, checked: bool, capsys) -> None:
    """The property, for one damaged bag."""
    before = _digest(bag)
    episodes = list(read_summary(original).episodes)
    info = run(["info", str(bag), "--json"], capsys)
    if info.code == 0:
        import json

        listed = json.loads(info.out)["episodes"]
        assert len(listed) <= EPISODES
        if checked:  # never a wrong episode: the first ones of the original, exactly
            assert listed == episodes[: len(listed)]
    else:
        assert info.code == 2 and info.one_line().startswith("bubblerob info: ")
    replay = run(["replay", str(bag)], capsys)
    assert replay.code in (0, 1, 2), replay
    if replay.code == 2:
        assert replay.one_line().startswith("bubblerob replay: ")
    elif replay.code == 1:  # a divergence, reported on stdout: the damage changed a message
        assert "first divergence at" in replay.out and "Traceback" not in replay.err
    elif checked:
        assert "replay matches the recording" in replay.out
    png = bag.parent / "map.png"
    mapped = run(["map", str(bag), "--out", str(png)], capsys)
    if mapped.code != 0:
        assert mapped.code == 2 and mapped.one_line().startswith("bubblerob map: ")
        assert not png.exists()
    recovered = run(["recover", str(bag)], capsys)
    assert (
        _digest(bag) == before or recovered.code == 0 and (bag.parent / f"{bag.name}.orig").exists()
    )
    if recovered.code != 0:
        assert recovered.code == 2 and recovered.one_line().startswith("bubblerob recover: ")
        return
    new = Path(recovered.out.split(" messages into ")[1].split(";")[0].split(" (those")[0])
    summary = read_summary(new)
    assert not summary.unfinished and 1 <= len(summary.episodes) <= EPISODES
    if checked:
        assert list(summary.episodes) == episodes[: len(summary.episodes)]


FLIPS = st.lists(
    st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(1, 255)), min_size=1, max_size=3
)


def _budget(examples: int) -> settings:
    return settings(
        max_examples=examples * SCALE,
        derandomize=SCALE == 1,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


@pytest.mark.parametrize(("fmt", "compression"), FORMAT_CASES)
@_budget(3)
@given(flips=FLIPS)
def test_flipped_bytes_give_a_right_answer_or_one_line(
    originals, tmp_path_factory, capsys, fmt, compression, flips
):
    original = originals[(fmt, compression)]
    bag = _damaged(original, tmp_path_factory.mktemp("flip"), None, flips)
    _check_commands(bag, original, (fmt, compression) in CHECKSUMMED, capsys)


@pytest.mark.parametrize(("fmt", "compression"), FORMAT_CASES)
@_budget(2)
@given(cut=st.floats(0.0, 1.0, exclude_max=True))
def test_truncated_bags_give_a_right_answer_or_one_line(
    originals, tmp_path_factory, capsys, fmt, compression, cut
):
    original = originals[(fmt, compression)]
    bag = _damaged(original, tmp_path_factory.mktemp("cut"), cut, [])
    _check_commands(bag, original, (fmt, compression) in CHECKSUMMED, capsys)
