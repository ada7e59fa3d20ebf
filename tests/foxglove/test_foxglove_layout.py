"""docs/foxglove/bubblerob.json: what ``layout.py`` writes, naming only topics the node has;
README's picture of it: what ``docs/foxglove/make_picture.py`` draws."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from layout import LAYOUT_FILE, layout_text

from bubblerob_env.ros.live.foxglove_robot import MARKER_TYPE, robot_model_topic
from bubblerob_env.ros.messages.topics import MSGTYPES, Topics

ROOT = Path(__file__).resolve().parents[2]
PICTURE_SCRIPT = ROOT / "docs" / "foxglove" / "make_picture.py"
PANEL_TYPES = {
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/scan": "sensor_msgs/msg/LaserScan",
    "/odom": "nav_msgs/msg/Odometry",
    "/bubblerob/robot_model": "visualization_msgs/msg/Marker",
    "/reward": "std_msgs/msg/Float64",
    "/camera/image_raw": "sensor_msgs/msg/Image",
    "/camera/camera_info": "sensor_msgs/msg/CameraInfo",
    "/cmd_vel": "geometry_msgs/msg/Twist",
}


def test_the_layout_file_is_what_layout_py_writes() -> None:
    assert LAYOUT_FILE.read_text() == layout_text(), "run: python tests/foxglove/layout.py"


def test_the_layout_names_the_nodes_topics_with_the_types_its_panels_show() -> None:
    saved = json.loads(LAYOUT_FILE.read_text())
    configs = saved["configById"]
    named = set(configs["3D!bubblerob"]["topics"])
    named |= {path["value"].split(".")[0] for path in configs["Plot!bubblerob"]["paths"]}
    image = configs["Image!bubblerob"]["imageMode"]
    named |= {image["imageTopic"], image["calibrationTopic"], configs["Teleop!bubblerob"]["topic"]}
    assert named == set(PANEL_TYPES)
    node_types = {name: MSGTYPES[key] for key, name in Topics().resolved().items()}
    node_types[robot_model_topic(Topics())] = MARKER_TYPE
    assert {topic: node_types[topic] for topic in named} == PANEL_TYPES
    # Every panel is placed in the layout tree, once.
    placed, stack = [], [saved["layout"]]
    while stack:
        node = stack.pop()
        if isinstance(node, str):
            placed.append(node)
        else:
            stack += [node["first"], node["second"]]
    assert sorted(placed) == sorted(configs)


def test_readmes_picture_of_the_layout_is_drawn_by_its_script(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("make_picture", PICTURE_SCRIPT)
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    script.OUT = tmp_path / "layout.png"
    script.main()
    assert script.OUT.read_bytes()[:4] == b"\x89PNG"
    assert "(docs/foxglove/layout.png)" in (ROOT / "README.md").read_text()
    assert (ROOT / "docs" / "foxglove" / "layout.png").is_file()
