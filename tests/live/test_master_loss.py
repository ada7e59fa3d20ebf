"""The node's master dies or restarts: the node says so and exits 1, for a supervisor to restart.

rospy never registers again with a new master: a node that went on would publish to nobody.
Each test runs its own master (the session's stays up for the other modules).
"""

from __future__ import annotations

import signal
import subprocess
import time

import pytest
from live_helpers import SKIP_REASON, Master, Node, free_port, stop

from bubblerob_env.ros.live.ros1 import check_master

pytestmark = pytest.mark.skipif(SKIP_REASON is not None, reason=SKIP_REASON or "")


def _start_master(master: Master, port: int) -> subprocess.Popen[str]:
    proc = master.popen(
        ["/usr/bin/rosmaster", "--core", "-p", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    check_master(master.uri, timeout=15)
    return proc


@pytest.mark.parametrize("restart", [False, True])
def test_the_node_exits_clearly_when_its_master_goes(tmp_path, restart):
    port = free_port()
    master = Master(port, tmp_path)
    proc = _start_master(master, port)
    node = None
    try:
        node = Node(master, ["--rate-factor", "1"])
        time.sleep(1.5)  # running, registered
        stop(proc, signal.SIGKILL)
        lost_at = time.monotonic()
        if restart:
            proc = _start_master(master, port)  # a new master that never heard of the node
        node.proc.wait(timeout=20)
        took = time.monotonic() - lost_at
        output = node.output
    finally:
        if node is not None:
            node.stop()
        stop(proc, signal.SIGKILL)
    assert node.proc.returncode == 1, output
    why = "restarted and no longer knows /bubblerob" if restart else "is gone"
    assert f"the ROS master at {master.uri} {why}" in output, output
    assert "exiting (start it again with the master)" in output
    assert took < 10, took
