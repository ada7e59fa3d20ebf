"""Several robots on one ``/clock``: a ``--no-clock`` robot starts its time at the shared clock."""

from __future__ import annotations

from live_helpers import requires_ros

pytestmark = requires_ros

EPOCH = 1_000_000_000  # 2001: far from the wall clock each robot would otherwise start at


def _first_secs(master, topic: str) -> int:
    result = master.run(["/usr/bin/rostopic", "echo", "-n", "1", f"{topic}/header/stamp/secs"])
    assert result.returncode == 0, result.stderr
    return int(result.stdout.split()[0])


def test_a_no_clock_robot_follows_the_shared_clock(master, start_node):
    first = start_node("--start-time", str(EPOCH), "--namespace", "clock_owner")
    second = start_node("--namespace", "follower", "--no-clock")
    owner = _first_secs(master, "/clock_owner/odom")
    follower = _first_secs(master, "/follower/odom")
    assert EPOCH <= owner < EPOCH + 120
    assert abs(follower - owner) <= 5, (owner, follower)  # not its own start, decades later
    assert "starting at the wall clock" not in second.output
    topics = master.run(["/usr/bin/rostopic", "info", "/clock"]).stdout
    publishers = topics.split("Subscribers:")[0]
    assert "/clock_owner/" in publishers and "/follower/" not in publishers  # one clock
    assert first.alive() and second.alive()
