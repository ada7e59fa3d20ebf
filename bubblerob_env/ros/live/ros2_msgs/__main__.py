"""``python -m bubblerob_env.ros.live.ros2_msgs``: build tf2_msgs and vision_msgs (a command shim).

The command is :mod:`bubblerob_cli.ros2_msgs`.
"""

import sys

from bubblerob_cli.ros2_msgs import main

if __name__ == "__main__":
    sys.exit(main())
