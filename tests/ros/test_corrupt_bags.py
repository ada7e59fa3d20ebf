"""Damaged bags and odd file layouts: one line naming the file and where, and nothing lost.

A bag is a path the user names (a file, or a folder that is one bag); a folder of several bags is
refused with its list. A finished bag with flipped bytes is *corrupt* (never "unfinished"), and
``recover`` salvages its complete episodes before the damage into a new bag beside it, leaving
the original byte for byte as it was.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest
from ros_helpers import FORMAT_CASES

from bubblerob_cli import main as cli
from bubblerob_env.ros.readback.layout import storage_file
from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary

EPISODES = 3


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, str], Path]:
    """One finished bag of three 15-step episodes per format and compression."""
    import gymnasium as gym
    from ros_helpers import drive

    from bubblerob_env.ros import RosBagRecorder

    root = tmp_path_factory.mktemp("bags")
    made = {}
    for fmt, compression in FORMAT_CASES:
        env = gym.make("BubbleRob-v0", max_episode_steps=15)
        name = f"{fmt}_{compression}"
        with RosBagRecorder(
            env, root / name, format=fmt, compression=compression, start_time=1.7e9
        ) as recorder:
            drive(recorder, EPISODES, 15)
        made[(fmt, compression)] = recorder.bag_paths[0]
    return made


def _copy(bag: Path, where: Path) -> Path:
    target = where / bag.name
    (shutil.copytree if bag.is_dir() else shutil.copyfile)(bag, target)
    return target


def _digest(path: Path) -> str:
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    return hashlib.sha256(b"".join(p.name.encode() + p.read_bytes() for p in files)).hexdigest()


def _one_line(err: str) -> str:
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


def test_a_folder_of_two_bags_is_refused_with_its_list(bags, tmp_path, capsys):
    two = tmp_path / "two"
    two.mkdir()
    for name, source in (("a.mcap", "a"), ("b.mcap", "b")):
        bag = bags[("mcap", "zstd")]
        shutil.copyfile(next(bag.glob("*.mcap")), two / name)
        del source
    (two / "notes.txt").write_text("hello")
    before = _digest(two)
    for command in ("info", "replay", "recover", "map"):
        assert cli.main([command, str(two)]) == 2
        line = _one_line(capsys.readouterr().err)
        assert line.startswith(f"bubblerob {command}: {two} is not one bag")
        assert "a.mcap, b.mcap, notes.txt" in line
    # Named, one file of the folder is that file alone: never the folder, never the other file.
    summary = read_summary(two / "b.mcap")
    assert summary.path == two / "b.mcap" and len(summary.episodes) == EPISODES
    assert replay_bag(two / "b.mcap").ok
    assert cli.main(["recover", str(two / "b.mcap")]) == 2  # finished: nothing to do
    assert "is a finished bag" in capsys.readouterr().err
    assert _digest(two) == before and sorted(p.name for p in tmp_path.iterdir()) == ["two"]


def test_a_storage_file_the_metadata_does_not_list_is_refused(bags, tmp_path, capsys):
    bag = _copy(bags[("mcap", "zstd")], tmp_path)
    stray = bag / "other.mcap"
    shutil.copyfile(storage_file(bag), stray)
    assert read_summary(bag).episodes  # the folder is the bag its metadata.yaml describes
    assert cli.main(["info", str(stray)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"{stray} is not part of the bag {bag}: its metadata.yaml lists {bag.name}.mcap" in line


def test_a_folder_of_per_episode_bags_is_refused(tmp_path, capsys):
    assert (
        cli.main(
            [
                "record",
                "--policy",
                "reactive",
                "--episodes",
                "2",
                "--max-steps",
                "3",
                "--per-episode",
                "--no-progress",
                "--out",
                str(tmp_path),
            ]
        )  # fmt: skip
        == 0
    )
    capsys.readouterr()
    folder = tmp_path / "bubblerob_reactive_seed0"
    assert cli.main(["info", str(folder)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "is not one bag" in line and "episode_000000/, episode_000001/" in line
    assert cli.main(["info", str(folder / "episode_000001")]) == 0


def _flip(bag: Path, fraction: float) -> tuple[Path, int]:
    """Flip every bit of one byte ``fraction`` of the way into the bag's storage file.

    ROS 1: ``fraction`` of the way into the last chunk (its index records after it carry no
    checksum, and no reader can tell a flipped byte there).
    """
    file = storage_file(bag)
    data = bytearray(file.read_bytes())
    offset = int(len(data) * fraction)
    if file.suffix == ".bag":
        last_chunk = data.rindex(b"op=\x05")
        offset = last_chunk + int((data.index(b"op=\x04", last_chunk) - last_chunk) * fraction)
    data[offset] ^= 0xFF
    file.write_bytes(bytes(data))
    return file, offset


@pytest.mark.parametrize(
    ("fmt", "compression"), [("mcap", "zstd"), ("mcap", "none"), ("ros1", "bz2"), ("ros1", "lz4")]
)
def test_a_finished_bag_with_a_flipped_byte_is_corrupt_and_recover_salvages(
    bags, tmp_path, capsys, fmt, compression
):
    bag = _copy(bags[(fmt, compression)], tmp_path)
    file, offset = _flip(bag, 0.8)  # in the last episode's chunk
    before = _digest(bag)
    for command in ("info", "replay", "map"):
        assert (
            cli.main(
                [command, str(bag), *(["--out", str(tmp_path / "m.png")] * (command == "map"))]
            )
            == 2
        )
        line = _one_line(capsys.readouterr().err)
        assert line.startswith(f"bubblerob {command}: corrupt bag: {file}: chunk ")
        assert "unfinished" not in line
    chunk_at = int(line.split(" at byte ")[1].split()[0])
    assert chunk_at <= offset  # the damaged chunk holds the flipped byte
    assert cli.main(["recover", str(bag)]) == 0
    out = capsys.readouterr().out
    salvaged = tmp_path / (
        f"{bag.stem}.recovered.bag" if fmt == "ros1" else f"{bag.name}.recovered"
    )
    assert out.startswith("salvaged ") and str(salvaged) in out and f"untouched at {bag}" in out
    assert _digest(bag) == before  # the original, byte for byte
    summary = read_summary(salvaged)
    assert not summary.unfinished and 1 <= len(summary.episodes) < EPISODES
    assert replay_bag(salvaged).ok
    original = read_summary(bags[(fmt, compression)]).episodes
    assert list(summary.episodes) == list(original[: len(summary.episodes)])
    assert cli.main(["recover", str(bag)]) == 2  # the salvage is there: never overwritten
    assert f"{salvaged} exists" in _one_line(capsys.readouterr().err)


def test_a_flipped_byte_in_an_mcap_summary_is_corrupt_too(bags, tmp_path, capsys):
    bag = _copy(bags[("mcap", "zstd")], tmp_path)
    file, _ = _flip(bag, 0.995)  # in the summary section, which no chunk CRC covers
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"bubblerob info: corrupt bag: {file}: the summary (bytes ")
    assert "fails its CRC" in line
    assert cli.main(["recover", str(bag)]) == 0  # every episode is before the damage
    assert f"salvaged {EPISODES} complete episode(s)" in capsys.readouterr().out


def test_a_corrupt_sqlite3_bag_is_one_line(bags, tmp_path, capsys):
    bag = _copy(bags[("sqlite3", "none")], tmp_path)
    file = storage_file(bag)
    data = bytearray(file.read_bytes())
    data[4096 : 4096 + 64] = b"\xff" * 64  # the first b-tree page after the header
    file.write_bytes(bytes(data))
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("bubblerob info: corrupt bag: ") and str(bag) in line


def test_episode_metadata_that_does_not_read_is_corrupt_not_fewer_episodes(bags, tmp_path, capsys):
    bag = _copy(bags[("ros1", "none")], tmp_path)  # no checksums: only the JSON can tell
    data = bytearray(bag.read_bytes())
    marker = b'"episode": 1'
    at = data.index(marker)
    data[at] = ord("!")
    bag.write_bytes(bytes(data))
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"bubblerob info: corrupt bag: {bag}: the episode metadata on ")
    assert "is damaged" in line


def test_an_unfinished_bag_is_still_read_as_unfinished(bags, tmp_path):
    bag = _copy(bags[("mcap", "zstd")], tmp_path)
    (bag / "metadata.yaml").unlink()
    file = storage_file(bag)
    file.write_bytes(file.read_bytes()[: file.stat().st_size * 3 // 4])  # killed mid-way
    summary = read_summary(bag)
    assert summary.unfinished and 1 <= len(summary.episodes) < EPISODES


def test_sqlite3_text_that_is_not_utf8_is_one_line_everywhere(bags, tmp_path, capsys):
    bag = _copy(bags[("sqlite3", "none")], tmp_path)  # found by tests/ros/test_bag_fuzz.py
    file = storage_file(bag)
    data = bytearray(file.read_bytes())
    at = data.index(b"/leftMotorSpeed")
    while at >= 0:  # in the topics table, its index, the metadata: SQLite's OperationalError
        data[at + 1] = 0xB9
        at = data.find(b"/leftMotorSpeed", at + 1)
    # In the schema table's SQL: SQLite's own error message quotes the byte, and Python's sqlite3
    # raises UnicodeDecodeError decoding it (the fuzz found this one).
    data[data.index(b"CREATE TABLE schema") + 2] = 0xB9
    file.write_bytes(bytes(data))
    before = _digest(bag)
    for command in ("info", "replay", "recover"):
        done = cli.main([command, str(bag)])
        err = capsys.readouterr().err
        assert done == 2 and _one_line(err).startswith(f"bubblerob {command}: "), err
    assert _digest(bag) == before


def _ros1_chunk_offsets(data: bytes) -> list[int]:
    """Where each chunk record starts (ROS 1 bag format 2.0: header length, header, data length,
    data; a chunk's header holds the field ``op=\\x05``)."""
    offsets, pos = [], len(b"#ROSBAG V2.0\n")
    while pos + 4 <= len(data):
        header_len = int.from_bytes(data[pos : pos + 4], "little")
        header = data[pos + 4 : pos + 4 + header_len]
        data_len = int.from_bytes(data[pos + 4 + header_len : pos + 8 + header_len], "little")
        if b"op=\x05" in header:
            offsets.append(pos)
        pos += 8 + header_len + data_len
    return offsets


def test_a_ros1_chunk_length_running_past_the_end_is_corrupt_not_unfinished(bags, tmp_path, capsys):
    bag = _copy(bags[("ros1", "none")], tmp_path)
    data = bytearray(bag.read_bytes())
    record = _ros1_chunk_offsets(bytes(data))[-1]
    header_len = int.from_bytes(data[record : record + 4], "little")
    data[record + 4 + header_len + 3] = 0x7F  # the chunk's data length: about 2 GB
    bag.write_bytes(bytes(data))
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"corrupt bag: {bag}: the record at byte {record} runs past the end of the file" in line


@pytest.mark.parametrize("compression", ["none", "bz2"])
def test_a_finished_ros1_bag_cut_inside_its_index_reads_every_episode(bags, tmp_path, compression):
    bag = _copy(bags[("ros1", compression)], tmp_path)
    data = bag.read_bytes()
    chunks = _ros1_chunk_offsets(data)
    index_at = int.from_bytes(data[data.index(b"index_pos=") + 10 :][:8], "little")
    assert chunks[-1] < index_at < len(data)
    bag.write_bytes(data[: (index_at + len(data)) // 2])  # the index half there
    summary = read_summary(bag)
    assert summary.unfinished and len(summary.episodes) == EPISODES
    assert replay_bag(bag).ok


def test_recovering_a_lone_storage_file_among_others_writes_beside_it(bags, tmp_path, capsys):
    folder = tmp_path / "mixed"
    folder.mkdir()
    data = storage_file(bags[("mcap", "zstd")]).read_bytes()
    (folder / "a.mcap").write_bytes(data[: len(data) * 3 // 4])  # killed: no footer
    (folder / "notes.txt").write_text("hello")
    before = _digest(folder / "a.mcap")
    assert cli.main(["recover", str(folder / "a.mcap")]) == 0
    out = capsys.readouterr().out
    assert f"into {folder / 'a.recovered'}; the unfinished original is untouched at" in out
    assert _digest(folder / "a.mcap") == before  # not renamed, not rewritten
    assert sorted(p.name for p in folder.iterdir()) == ["a.mcap", "a.recovered", "notes.txt"]
    assert replay_bag(folder / "a.recovered").ok


def test_a_damaged_metadata_yaml_is_corrupt_and_recover_salvages_from_the_storage_file(
    bags, tmp_path, capsys
):
    bag = _copy(bags[("mcap", "zstd")], tmp_path)
    metadata = bag / "metadata.yaml"
    metadata.write_text(
        metadata.read_text().replace("relative_file_paths:", "relative_file_p@ths:")
    )
    before = _digest(bag)
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"bubblerob info: corrupt bag: {metadata} does not read as rosbag2")
    assert cli.main(["recover", str(bag)]) == 0
    assert f"salvaged {EPISODES} complete episode(s)" in capsys.readouterr().out
    assert _digest(bag) == before and replay_bag(tmp_path / f"{bag.name}.recovered").ok


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3"])
def test_a_wrong_count_in_metadata_yaml_is_corrupt_not_printed(bags, tmp_path, capsys, fmt):
    bag = _copy(bags[(fmt, "zstd" if fmt == "mcap" else "none")], tmp_path)
    metadata = bag / "metadata.yaml"
    text = metadata.read_text()
    topic_at = text.index("name: /odom")  # its list item starts with its count
    count_at = text.rindex("message_count: ", 0, topic_at) + len("message_count: ")
    count = int(text[count_at:].split()[0])
    metadata.write_text(text[:count_at] + str(count + 1) + text[count_at + len(str(count)) :])
    assert cli.main(["info", str(bag)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"{metadata} counts {count + 1} messages on /odom, " in line
    assert line.endswith(f"holds {count}")
    assert cli.main(["recover", str(bag)]) == 0  # the storage file is whole
    assert f"salvaged {EPISODES} complete episode(s)" in capsys.readouterr().out
