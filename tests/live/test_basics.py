"""Backend import, message definitions, errors, control decoding, launch and rviz files."""

from __future__ import annotations

import json
import math
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from live_helpers import free_port, requires_ros

from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.ros.live import ControlState, MasterUnreachableError, RosUnavailableError
from bubblerob_env.ros.live import ros1 as ros1_backend
from bubblerob_env.ros.live.controls import ControlError, decode_control
from bubblerob_env.ros.live.node import LAUNCH_DIR
from bubblerob_env.ros.live.ros1 import check_master, ros1_msgdef

DRIVE = DiffDrive(0.04, 0.18, 10.0)
TYPES = [
    "sensor_msgs/msg/LaserScan", "sensor_msgs/msg/Range", "sensor_msgs/msg/Image",
    "sensor_msgs/msg/CameraInfo", "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage",
    "rosgraph_msgs/msg/Clock", "std_msgs/msg/Float32", "std_msgs/msg/Float64",
    "std_msgs/msg/Bool", "std_msgs/msg/Int32", "std_msgs/msg/String",
    "std_msgs/msg/Float64MultiArray", "geometry_msgs/msg/Twist",
]  # fmt: skip


@requires_ros
def test_rospy_imports_from_the_venv_and_keeps_its_numpy():
    code = (
        "import sys, numpy; from bubblerob_env.ros.live.ros1 import import_rospy; "
        "r = import_rospy(); import numpy as n; import json; "
        "print(json.dumps([r.__file__, n.__file__, sys.path[-1], sys.path.index('"
        + ros1_backend.DEBIAN_DIST_PACKAGES
        + "') == len(sys.path) - 1]))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    rospy_file, numpy_file, last, appended = json.loads(result.stdout)
    assert rospy_file.startswith("/usr/lib/python3/dist-packages/")
    assert numpy_file.startswith(str(Path(sys.prefix)))  # the venv's numpy, not Debian's
    assert appended and last == ros1_backend.DEBIAN_DIST_PACKAGES


@requires_ros
def test_definitions_match_debians_message_classes():
    script = (
        "import importlib, json, sys\n"
        "out = {}\n"
        "for name in sys.argv[1:]:\n"
        "    pkg, _, typ = name.split('/')\n"
        "    cls = getattr(importlib.import_module(pkg + '.msg'), typ)\n"
        "    out[name] = [cls._type, cls._md5sum]\n"
        "print(json.dumps(out))\n"
    )
    result = subprocess.run(
        ["/usr/bin/python3", "-c", script, *TYPES],
        env={"PATH": "/usr/bin:/bin", "HOME": "/tmp"},
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    debian = json.loads(result.stdout)
    for msgtype in TYPES:
        name, md5sum, text = ros1_msgdef(msgtype)
        assert [name, md5sum] == debian[msgtype], msgtype
        assert text


def test_missing_rospy_names_the_debian_package(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "rospy", None)  # makes `import rospy` fail
    monkeypatch.setattr(ros1_backend, "DEBIAN_DIST_PACKAGES", str(tmp_path / "absent"))
    with pytest.raises(RosUnavailableError, match="python3-rospy"):
        ros1_backend.import_rospy()


def test_no_master_fails_within_5_s_naming_ros_master_uri(monkeypatch):
    uri = f"http://127.0.0.1:{free_port()}/"
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    start = time.monotonic()
    with pytest.raises(MasterUnreachableError, match="ROS_MASTER_URI") as error:
        check_master(timeout=3.0)
    assert time.monotonic() - start < 5.0
    assert uri in str(error.value) and "roscore" in str(error.value)


@requires_ros
def test_node_without_master_exits_with_a_clear_message():
    env = {"ROS_MASTER_URI": f"http://127.0.0.1:{free_port()}/", "ROS_HOSTNAME": "127.0.0.1"}
    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "node"],
        env={**__import__("os").environ, **env},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert "ROS_MASTER_URI=" + env["ROS_MASTER_URI"] in result.stderr
    assert "no ROS master reachable" in result.stderr
    assert time.monotonic() - start < 30  # 3 s of waiting plus the imports on a loaded box


def test_decode_control_ros1():
    assert decode_control("bool", b"\x01", "ros1") is True
    assert decode_control("float32", struct.pack("<f", 2.5), "ros1") == 2.5
    assert decode_control("twist", struct.pack("<6d", 0.2, 0, 0, 0, 0, -1.0), "ros1") == (0.2, -1.0)
    for kind, raw in [
        ("twist", b"\x00" * 8),
        ("float32", struct.pack("<f", math.nan)),
        ("twist", struct.pack("<6d", math.inf, 0, 0, 0, 0, 0)),
        ("bool", b"\x05"),
        ("bool", b""),
    ]:
        with pytest.raises(ControlError):
            decode_control(kind, raw, "ros1")


def test_decode_control_cdr():
    from bubblerob_env.ros.messages.distros import typestore

    store = typestore("jazzy")
    t = store.types
    twist = t["geometry_msgs/msg/Twist"](
        linear=t["geometry_msgs/msg/Vector3"](x=0.3, y=0.0, z=0.0),
        angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.5),
    )
    raw = bytes(store.serialize_cdr(twist, "geometry_msgs/msg/Twist"))
    assert decode_control("twist", raw, "cdr") == (0.3, 0.5)
    with pytest.raises(ControlError):
        decode_control("twist", raw[:10], "cdr")


def test_control_state_last_command_wins_and_watchdog():
    state = ControlState(DRIVE, watchdog=0.5)
    assert state.action(0.0).tolist() == [0.0, 0.0]
    state.command_wheel(0, 5.0)
    state.command_wheel(1, 2.5)
    assert state.action(0.1).tolist() == [0.5, 0.25]
    state.command_twist(0.2, 0.0)  # cmd_vel overrides both wheels: 0.2 m/s = 5 rad/s
    assert np.allclose(state.action(0.2), [0.5, 0.5])
    state.command_twist(0.0, 1.0)  # turning left: the right wheel forward (received at 0.2 s)
    left, right = state.action(0.3)
    assert left < 0 < right
    assert state.action(0.7).tolist() != [0.0, 0.0]  # 0.5 s after the command: still on
    assert state.action(0.75).tolist() == [0.0, 0.0]  # watchdog
    assert state.watchdog_trips == 1
    state.command_wheel(0, 20.0)  # beyond the limit: passed on, the env clips it to 1
    assert state.action(0.8)[0] == pytest.approx(2.0)


def test_launch_dir_holds_a_ros_package_launch_and_rviz():
    assert (LAUNCH_DIR / "package.xml").is_file()
    config = yaml.safe_load((LAUNCH_DIR / "bubblerob.rviz").read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "odom"
    displays = {d["Class"]: d for d in manager["Displays"]}
    # relative names: they resolve in the namespace the launch file starts rviz in
    assert displays["rviz/LaserScan"]["Topic"] == "scan"
    assert displays["rviz/Odometry"]["Topic"] == "odom"
    assert displays["rviz/Image"]["Image Topic"] == "camera/image_raw"
    assert "rviz/TF" in displays
    assert displays["rviz/Map"]["Topic"] == "map"  # the latched ground-truth /map


@requires_ros
def test_roslaunch_parses_the_launch_file():
    env = {"PATH": "/usr/bin:/bin", "HOME": "/tmp", "ROS_PACKAGE_PATH": str(LAUNCH_DIR)}
    launch = str(LAUNCH_DIR / "bubblerob.launch")

    def roslaunch(*args: str) -> str:
        result = subprocess.run(
            ["/usr/bin/roslaunch", *args], env=env, capture_output=True, text=True, timeout=60
        )
        assert result.returncode == 0, result.stdout + result.stderr
        return result.stdout

    assert roslaunch("--nodes", launch, "rviz:=true").split() == ["/bubblerob", "/rviz"]
    command = roslaunch("--args", "/r2", launch, "sync:=true", "ns:=r2", "name:=r2")
    assert "scripts/bubblerob_node --namespace=r2 --seed 0 --sync" in command
    command = roslaunch("--args", "/bubblerob", launch, "rate:=max")
    assert "--rate-factor max --camera" in command
    assert "--map-resolution 0.05 " in command  # the default, as `bubblerob node`
    command = roslaunch("--args", "/bubblerob", launch, "map_resolution:=0.1")
    assert "--map-resolution 0.1 " in command


LAUNCH_NODES = """
import sys
import roslaunch.config
sys.argv = ["roslaunch", *sys.argv[1:]]
config = roslaunch.config.load_config_default(["bubblerob.launch"], None)
for node in config.nodes:
    print(node.name, node.namespace, node.args)
"""


@requires_ros
@pytest.mark.parametrize(
    ("ns", "rviz_namespace", "fixed_frame"),
    [("", "/", "odom"), ("robot2", "/robot2/", "robot2/odom")],
)
def test_launch_file_puts_rviz_in_the_robots_namespace_and_frames(ns, rviz_namespace, fixed_frame):
    # README's second-robot command. rviz itself is not installed here: roslaunch's own loader
    # shows what it would start.
    result = subprocess.run(
        [
            "/usr/bin/python3",
            "-c",
            LAUNCH_NODES,
            f"ns:={ns}",
            "name:=r",
            "clock:=false",
            "rviz:=true",
        ],
        cwd=LAUNCH_DIR,
        env={"PATH": "/usr/bin:/bin", "HOME": "/tmp", "ROS_PACKAGE_PATH": str(LAUNCH_DIR)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    nodes = {line.split()[0]: line.split(maxsplit=2)[1:] for line in result.stdout.splitlines()}
    assert nodes["rviz"][0] == rviz_namespace
    assert nodes["rviz"][1].endswith(f"bubblerob.rviz -f {fixed_frame}")
    assert "--no-clock" in nodes["r"][1]  # clock:=false: another robot publishes /clock


@requires_ros
def test_launch_file_passes_env_env_kwargs_and_topics_to_the_node():
    # roslaunch splits a node's args with shlex: the JSON object stays one argument.
    import shlex

    from bubblerob_cli.main import build_parser

    kwargs = '{"num_obstacles": [0, 0], "start_pose": [0, 0, 0]}'
    result = subprocess.run(
        ["/usr/bin/python3", "-c", LAUNCH_NODES, "env:=PioneerP3DX-v0", "topics:=vrep",
         f"env_kwargs:={kwargs}"],
        cwd=LAUNCH_DIR,
        env={"PATH": "/usr/bin:/bin", "HOME": "/tmp", "ROS_PACKAGE_PATH": str(LAUNCH_DIR)},
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if line.startswith("bubblerob "))
    args = build_parser().parse_args(["node", *shlex.split(line.split(maxsplit=2)[2])])
    assert (args.env, args.topics) == ("PioneerP3DX-v0", "vrep")
    assert args.env_kwargs == {"num_obstacles": [0, 0], "start_pose": [0, 0, 0]}
