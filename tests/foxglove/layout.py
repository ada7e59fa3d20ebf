"""The Foxglove layout of README's "Watch it live in Foxglove": docs/foxglove/bubblerob.json.

Each panel's settings are spelled by Foxglove's own SDK (``foxglove.layouts``, the classes behind
its notebook layouts), and put together in the file format Foxglove's "Import from file..." reads
and "Export to file..." writes (``configById``, ``layout``). ``python tests/foxglove/layout.py``
writes the file again; ``test_foxglove_layout.py`` checks that it is what this script writes and
that every topic it names is one the node publishes (or, for the Teleop panel, reads).

- 3D: the map, the laser scan (coloured by range), the robot's body (a cylinder on base_link),
  the odometry pose and the tf frames, seen from above in the ``map`` frame;
- Image: the camera (``bubblerob node --camera``);
- Plot: the robot's forward and turning speed (``/odom``) and the reward;
- Teleop: arrows publish ``geometry_msgs/Twist`` on ``/cmd_vel`` (0.2 m/s, 1 rad/s), 10 per second.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

LAYOUT_FILE = Path(__file__).resolve().parents[2] / "docs" / "foxglove" / "bubblerob.json"
PANEL_IDS = {"3D": "3D!bubblerob", "Image": "Image!bubblerob", "Plot": "Plot!bubblerob"}
PANEL_IDS |= {"Teleop": "Teleop!bubblerob"}


def _config(model: Any) -> Any:
    """An SDK layout object as the JSON the app stores (``None`` fields left out)."""
    return json.loads(model.to_json())


def panel_configs() -> dict[str, Any]:
    """Each panel's settings, by panel id."""
    import foxglove.layouts as fl

    scan = fl.BaseRendererLaserScanTopicSettings(
        visible=True, point_size=4, color_mode="colormap", color_field="range", color_map="turbo"
    )
    three_d = fl.ThreeDeeConfig(
        follow_tf="map",
        camera_state=fl.ThreeDeeCameraState(
            distance=7, perspective=False, phi=0, theta_offset=90, target=(0, 0, 0)
        ),
        topics={
            "/map": fl.BaseRendererRosOccupancyGridTopicSettings(visible=True, alpha=0.8),
            "/scan": scan,
            "/bubblerob/robot_model": fl.BaseRendererRosMarkerTopicSettings(visible=True),
            "/odom": fl.BaseRendererPoseTopicSettings(
                visible=True, type="arrow", arrow_scale=(0.3, 0.05, 0.05)
            ),
        },
        layers={"grid": fl.BaseRendererGridLayerSettings(visible=True, frame_id="map", size=5)},
    )
    image = fl.ImageConfig(
        image_mode=fl.ImageModeConfig(
            image_topic="/camera/image_raw", calibration_topic="/camera/camera_info"
        )
    )
    series = [
        ("/odom.twist.twist.linear.x", "forward speed (m/s)"),
        ("/odom.twist.twist.angular.z", "turning speed (rad/s)"),
        ("/reward.data", "reward"),
    ]
    plot = fl.PlotConfig(
        paths=[
            fl.PlotSeries(value=path, label=label, enabled=True, timestamp_method="receiveTime")
            for path, label in series
        ],
        show_legend=True,
        x_axis_val="timestamp",
        following_view_width=30,
    )
    teleop = fl.TeleopConfig(
        topic="/cmd_vel",
        publish_rate=10,
        up_button=fl.TeleopButton(field="linear-x", value=0.2),
        down_button=fl.TeleopButton(field="linear-x", value=-0.2),
        left_button=fl.TeleopButton(field="angular-z", value=1.0),
        right_button=fl.TeleopButton(field="angular-z", value=-1.0),
        stop_button=fl.TeleopButton(field="linear-x", value=0.0),
        auto_send_stop_on_release=True,
    )
    models = {"3D": three_d, "Image": image, "Plot": plot, "Teleop": teleop}
    return {PANEL_IDS[kind]: _config(model) for kind, model in models.items()}


def layout() -> dict[str, Any]:
    """The layout file's content: 3D on the left; image, plot and teleop stacked on the right."""
    right = {
        "direction": "column",
        "first": PANEL_IDS["Image"],
        "second": {
            "direction": "column",
            "first": PANEL_IDS["Plot"],
            "second": PANEL_IDS["Teleop"],
            "splitPercentage": 55,
        },
        "splitPercentage": 40,
    }
    return {
        "configById": panel_configs(),
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {
            "direction": "row",
            "first": PANEL_IDS["3D"],
            "second": right,
            "splitPercentage": 62,
        },
    }


def layout_text() -> str:
    """The file's text (indented JSON, a final newline)."""
    return json.dumps(layout(), indent=2) + "\n"


if __name__ == "__main__":
    LAYOUT_FILE.parent.mkdir(parents=True, exist_ok=True)
    LAYOUT_FILE.write_text(layout_text())
    sys.stdout.write(f"wrote {LAYOUT_FILE}\n")
