"""What the messages are.

Topic names (``topics``), distros and the ROS 1/CDR switch (``distros``), genuine ROS 1
definitions kept as ``.msg`` data (``definitions``), the field values of a frame (``values``) and
the messages built from them (``convert``). Imports nothing else of ``bubblerob_env.ros``.
"""
