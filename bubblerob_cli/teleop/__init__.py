"""``bubblerob teleop``: drive the robot from the keyboard, simulated or a live ROS node.

- :mod:`~bubblerob_cli.teleop.keys`: the keys, the commanded twist and the pacing both share;
- :mod:`~bubblerob_cli.teleop.sim`: the local drive of a simulated env;
- :mod:`~bubblerob_cli.teleop.ros`: the drive of a running ``bubblerob node`` over ``cmd_vel``;
- :mod:`~bubblerob_cli.teleop.cli`: the subcommand, its options and its exits.
"""

from bubblerob_cli.teleop.cli import add_subcommands

__all__ = ["add_subcommands"]
