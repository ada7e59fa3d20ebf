"""RosBagRecorder: what goes in the bag, field by field, for every format."""

from __future__ import annotations

import json
import math
import time

import gymnasium as gym
import numpy as np
import pytest
from ros_helpers import FORMAT_CASES, FORWARD, drive, read_all

from bubblerob_env.ros import RosBagRecorder, Topics, recorded_env_fns
from bubblerob_env.ros.bags.sinks import BagPathError, bag_path
from bubblerob_env.ros.messages.convert import RosConverter
from bubblerob_env.ros.readback.summary import read_summary
from bubblerob_env.specs import EnvSpecs

STEP_TOPICS = ("/cmd_vel", "/leftMotorSpeed", "/rightMotorSpeed", "/bubblerob/action", "/reward")


@pytest.mark.parametrize(("fmt", "compression"), FORMAT_CASES)
def test_round_trip_observations_field_by_field(tmp_path, fmt, compression):
    env = gym.make("BubbleRob-v0", camera=True, camera_width=8, camera_height=6)
    frames = []
    with RosBagRecorder(env, tmp_path / "bag", format=fmt, compression=compression) as recorder:
        obs, info = recorder.reset(seed=1)
        frames.append((obs, info, None, 0.0))
        for _ in range(5):
            obs, reward, _, _, info = recorder.step(FORWARD)
            frames.append((obs, info, FORWARD, reward))
    spec = env.unwrapped.laser_spec
    messages = read_all(recorder.bag_paths[0])
    for topic in ("/scan", "/proximity", "/odom", "/tf", "/camera/image_raw", "/clock"):
        assert len(messages[topic]) == len(frames), topic
    for topic in STEP_TOPICS:
        assert len(messages[topic]) == len(frames) - 1, topic
    start = recorder.start_time_ns
    assert abs(start - time.time_ns()) < 600 * 10**9  # by default, the wall clock at the start
    for i, (obs, info, action, reward) in enumerate(frames):
        stamp = start + round(info["sim_time"] * 1e9)
        _, scan = messages["/scan"][i]
        expected = np.where(obs["laser"] >= spec.range_max, np.inf, obs["laser"])
        np.testing.assert_array_equal(scan.ranges, expected.astype(np.float32))
        assert scan.header.stamp.sec * 10**9 + scan.header.stamp.nanosec == stamp
        _, proximity = messages["/proximity"][i]
        assert proximity.range == obs["proximity"][0] or math.isinf(proximity.range)
        _, image = messages["/camera/image_raw"][i]
        np.testing.assert_array_equal(image.data.reshape(6, 8, 3), obs["camera"])
        _, odom = messages["/odom"][i]
        pose = odom.pose.pose
        assert (pose.position.x, pose.position.y, pose.position.z) == tuple(info["position"])
        w, x, y, z = info["quaternion_wxyz"]
        assert (pose.orientation.x, pose.orientation.y, pose.orientation.z) == (x, y, z)
        assert pose.orientation.w == w
        twist = odom.twist.twist
        assert (twist.linear.x, twist.angular.z) == (info["body_twist"][0], info["body_twist"][5])
        assert np.float32(twist.linear.x) == obs["velocity"][0]  # the observed forward speed
        _, trigger = messages["/sensorTrigger"][i]
        assert trigger.data == info["proximity_triggered"]
        if action is not None:
            _, raw = messages["/bubblerob/action"][i - 1]
            np.testing.assert_array_equal(raw.data, action.astype(np.float64))
            _, left = messages["/leftMotorSpeed"][i - 1]
            assert left.data == np.float32(info["wheel_command"][0])
            assert messages["/reward"][i - 1][1].data == reward


def test_laser_scan_sees_the_walls_at_their_bearing_and_distance(tmp_path, wall_env_factory):
    env = wall_env_factory()
    with RosBagRecorder(env, tmp_path / "bag") as recorder:
        recorder.reset(seed=0)
    _, scan = read_all(recorder.bag_paths[0])["/scan"][0]
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    laser_x = -0.015  # laser_link in base_link; base_link at the origin facing +x
    ahead = int(np.argmin(np.abs(angles)))
    left = int(np.argmin(np.abs(angles - math.pi / 2)))
    assert angles[ahead] == pytest.approx(0.0, abs=1e-6)
    assert angles[left] == pytest.approx(math.pi / 2, abs=1e-6)
    assert scan.ranges[ahead] == pytest.approx(1.0 - laser_x, abs=1e-3)
    assert scan.ranges[left] == pytest.approx(0.7, abs=1e-3)
    assert scan.header.frame_id == "laser_link"


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_tf_tree_is_complete_and_follows_rep_105(record, fmt):
    messages = read_all(record(fmt, episodes=1, steps=3, env_kwargs={"camera": True}))
    ((_, static),) = messages["/tf_static"]
    edges = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
    for _, tf in messages["/tf"]:
        edges |= {(t.header.frame_id, t.child_frame_id) for t in tf.transforms}
    parents = {child: parent for parent, child in edges}
    assert len(parents) == len(edges)  # a tree: one parent per frame
    sensor_frames = {"laser_link", "proximity_link", "camera_link", "camera_optical_frame"}
    for frame in {"base_link", *sensor_frames}:
        chain = [frame]
        while chain[-1] in parents:
            chain.append(parents[chain[-1]])
        assert chain[-2:] == ["odom", "map"], chain
    assert parents["base_link"] == "odom"
    assert parents["odom"] == "map"  # REP 105: map is the parent of odom (identity here)
    map_odom = next(t for t in static.transforms if t.child_frame_id == "odom")
    assert map_odom.transform.rotation.w == 1.0 and map_odom.transform.translation.x == 0.0
    _, odom = messages["/odom"][0]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    laser = next(t for t in static.transforms if t.child_frame_id == "laser_link")
    translation = laser.transform.translation
    assert (translation.x, translation.y, translation.z) == pytest.approx((-0.015, 0.0, 0.14))


@pytest.mark.parametrize(("fmt", "compression"), [("mcap", None), ("ros1", "none")])
def test_time_increases_strictly_across_episodes(tmp_path, fmt, compression):
    env = gym.make("BubbleRob-v0")
    with RosBagRecorder(env, tmp_path / "bag", format=fmt, compression=compression) as recorder:
        drive(recorder, episodes=3, steps=8)
    path = recorder.bag_paths[0]
    messages = read_all(path)
    clock = [stamp for stamp, _ in messages["/clock"]]
    assert all(b > a for a, b in zip(clock, clock[1:], strict=False))
    assert [stamp for stamp, _ in messages["/clock"]] == [
        m.clock.sec * 10**9 + m.clock.nanosec for _, m in messages["/clock"]
    ]
    episodes = read_summary(path).episodes
    starts = [e["start_time_ns"] for e in episodes]
    assert len(starts) == 3 and starts[0] == recorder.start_time_ns == clock[0]
    dt = round(env.unwrapped.dt * 1e9)
    for start, (stamp, _) in zip(
        starts[1:], [messages["/clock"][9], messages["/clock"][18]], strict=True
    ):
        assert stamp == start  # episode 2 starts one control step after episode 1 ended
        assert start == messages["/clock"][clock.index(start) - 1][0] + dt
    # /simulationTime is the simulated time of the episode (CoppeliaSim's simTime: 0 at the
    # start of a simulation, one dt per step), as float32; before 2026-11-25 it held the stamp.
    expected = np.tile(np.arange(9) * env.unwrapped.dt, 3).astype(np.float32)
    sim_time = np.array([m.data for _, m in messages["/simulationTime"]], dtype=np.float32)
    np.testing.assert_array_equal(sim_time, expected)


def test_actions_are_logged_when_sent_and_results_after_the_step(record):
    messages = read_all(record("mcap", episodes=1, steps=3))
    clock = [stamp for stamp, _ in messages["/clock"]]
    assert [s for s, _ in messages["/cmd_vel"]] == clock[:-1]
    assert [s for s, _ in messages["/reward"]] == clock[1:]


def test_episode_metadata_is_stored_with_each_episode(record):
    path = record("mcap", episodes=2, metadata={"policy": "forward"}, steps=4)
    summary = read_summary(path)
    assert [e["episode"] for e in summary.episodes] == [0, 1]
    first = summary.episodes[0]
    assert (first["env_id"], first["seed"], first["policy"]) == ("BubbleRob-v0", 0, "forward")
    assert first["distro"] == "jazzy" and first["max_episode_steps"] == 1000
    import yaml

    custom = yaml.safe_load((path / "metadata.yaml").read_text())
    stored = custom["rosbag2_bagfile_information"]["custom_data"]
    assert [e["seed"] for e in json.loads(stored["bubblerob.episodes"])] == [0, 1]
    recording = json.loads(stored["bubblerob.recording"])
    assert (recording["env_id"], recording["policy"]) == ("BubbleRob-v0", "forward")


def test_reserved_metadata_keys_are_rejected(tmp_path):
    with pytest.raises(ValueError, match="reserved"):
        RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", metadata={"seed": 1})


def test_one_bag_per_episode(tmp_path):
    with RosBagRecorder(
        gym.make("BubbleRob-v0"),
        tmp_path / "run",
        format="ros1",
        per_episode=True,
        start_time="2024-05-01T12:00:00Z",
    ) as recorder:
        drive(recorder, episodes=3, steps=4)
    assert [p.name for p in recorder.bag_paths] == [f"episode_00000{i}.bag" for i in range(3)]
    for i, path in enumerate(recorder.bag_paths):
        summary = read_summary(path)
        assert [e["episode"] for e in summary.episodes] == [i]
        assert summary.start_ns == 1714564800 * 10**9
        assert len(read_all(path)["/tf_static"]) == 1  # every bag starts with its own


def test_tf_static_is_recorded_once_per_bag(record):
    messages = read_all(record("mcap", episodes=3, steps=4, start_time=1700000000.25))
    assert len(messages["/bubblerob/episode"]) == 3
    ((stamp, static),) = messages["/tf_static"]  # latched: once, before the first episode's frame
    assert stamp == 1700000000_250000000 == messages["/clock"][0][0]
    for transform in static.transforms:  # tf2 ignores nothing stamped at a real time
        assert (transform.header.stamp.sec, transform.header.stamp.nanosec) == (1700000000, 25e7)


@pytest.mark.parametrize("start_time", [0, -1, "2040-01-01", "yesterday", float("nan")])
def test_bad_start_times_are_rejected(tmp_path, start_time):
    with pytest.raises(ValueError, match="start time"):
        RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", start_time=start_time)
    assert not (tmp_path / "bag").exists()


def test_custom_topic_names_and_namespace(tmp_path):
    topics = Topics(scan="/base_scan", sensor_trigger=None, namespace="robot1")
    with RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", topics=topics) as recorder:
        drive(recorder, episodes=1, steps=2)
    names = {t.name for t in read_summary(recorder.bag_paths[0]).topics}
    assert {"/robot1/base_scan", "/robot1/cmd_vel", "/tf", "/clock"} <= names
    assert not any("sensorTrigger" in n for n in names)


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_namespace_prefixes_every_frame_id(tmp_path, fmt):
    # /tf is shared by all robots in a graph: robot2's tree must not collide with robot1's.
    topics = Topics(namespace="robot2")
    with RosBagRecorder(
        gym.make("BubbleRob-v0"), tmp_path / "bag", format=fmt, topics=topics
    ) as recorder:
        drive(recorder, episodes=1, steps=2)
    messages = read_all(recorder.bag_paths[0])
    (_, tf), *_ = messages["/tf"]
    assert [(t.header.frame_id, t.child_frame_id) for t in tf.transforms] == [
        ("robot2/odom", "robot2/base_link")
    ]
    (_, odom), *_ = messages["/robot2/odom"]
    assert (odom.header.frame_id, odom.child_frame_id) == ("robot2/odom", "robot2/base_link")
    (_, scan), *_ = messages["/robot2/scan"]
    assert scan.header.frame_id == "robot2/laser_link"
    (_, static), *_ = messages["/tf_static"]
    parents = {t.header.frame_id for t in static.transforms}
    children = {t.child_frame_id for t in static.transforms}
    assert "robot2/base_link" in parents and "robot2/laser_link" in children
    assert all(frame.startswith("robot2/") for frame in parents | children)


def test_frame_prefix_must_end_with_a_slash():
    specs = EnvSpecs.from_env(gym.make("BubbleRob-v0"))
    for bad in ("/robot2/", "robot2"):
        with pytest.raises(ValueError, match=repr(bad)):
            RosConverter(specs, "jazzy", frame_prefix=bad)


def test_existing_bag_raises_before_the_env_is_used(tmp_path, record):
    record("mcap", episodes=1, steps=1)
    env = gym.make("BubbleRob-v0")
    with pytest.raises(FileExistsError, match=str(tmp_path / "bag")):
        RosBagRecorder(env, tmp_path / "bag")
    overwritten = RosBagRecorder(env, tmp_path / "bag", overwrite=True)
    overwritten.close()


def test_unwritable_directory_raises_before_the_first_step(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(BagPathError, match=str(tmp_path / "file")):
        RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "file" / "bag", format="sqlite3")


@pytest.mark.parametrize(
    ("vector_env", "fmt"),
    [(gym.vector.SyncVectorEnv, "ros1"), (gym.vector.AsyncVectorEnv, "mcap")],
    ids=["sync-ros1", "async-mcap"],
)
def test_vector_env_records_one_bag_per_sub_env(tmp_path, vector_env, fmt):
    # AsyncVectorEnv makes (and closes, unused) a first env to read the spaces: its bag must not
    # stand in the way of the worker's.
    fns = recorded_env_fns(
        "BubbleRob-v0", 2, tmp_path / "vec", env_kwargs={"max_episode_steps": 5}, format=fmt
    )
    envs = vector_env(fns)
    envs.reset(seed=10)
    for _ in range(7):
        envs.step(np.tile(FORWARD, (2, 1)))
    envs.close()
    for i in range(2):
        summary = read_summary(bag_path(tmp_path / "vec" / f"env_{i}", fmt))
        seeds = [e["seed"] for e in summary.episodes]
        assert seeds[0] == 10 + i and len(seeds) == 2  # autoreset after 5 steps
        assert {t.name: t.count for t in summary.topics}["/cmd_vel"] == 6


def test_recorder_closed_before_any_reset_leaves_no_bag(tmp_path):
    recorder = RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag")
    assert (tmp_path / "bag").is_dir()
    recorder.close()
    assert not (tmp_path / "bag").exists() and recorder.bag_paths == []
