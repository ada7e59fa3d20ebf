"""A move_base user of ``bubblerob node --env BubbleRobNav-v0 --sync``: real rospy (Debian's).

With ``--initial X Y``, first an ``/initialpose`` there and one step. With ``--bad-goals``, three
goals the node must refuse (a frame it does not know, a point outside the arena, one in the
wall). Then ``--goal X Y`` in ``--frame``, and steps until ``/goal_reached`` says True (at most
``--max-steps``). Prints one JSON line: the latched goals and plans seen (the episode's drawn one
first), the ``/goal_reached`` values, the steps triggered and every ``/odom`` position.
"""

import argparse
import json
import threading
import time

import rospy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry, Path
from std_msgs.msg import Bool
from tf2_msgs.msg import TFMessage


class Kept:
    def __init__(self, topic, cls):
        self.all = []
        self.event = threading.Event()
        self.sub = rospy.Subscriber(topic, cls, self._cb, tcp_nodelay=True, queue_size=None)

    def _cb(self, msg):
        self.all.append(msg)
        self.event.set()

    def wait(self, count, timeout=10.0):
        end = time.monotonic() + timeout
        while len(self.all) < count:
            if time.monotonic() > end:
                raise SystemExit(f"{self.sub.name}: {len(self.all)} messages, expected {count}")
            time.sleep(0.01)


def goal_message(x, y, frame):
    msg = PoseStamped()
    msg.header.frame_id = frame
    msg.header.stamp = rospy.Time.now()
    msg.pose.position.x, msg.pose.position.y = x, y
    msg.pose.orientation.w = 1.0
    return msg


def initial_pose(xy, trigger, done):
    """Send an /initialpose at ``xy`` (heading 0, 1 cm), step once; /amcl_pose and map -> odom."""
    amcl = Kept("/amcl_pose", PoseWithCovarianceStamped)
    tf = Kept("/tf", TFMessage)
    pub = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = "map"
    msg.pose.pose.position.x, msg.pose.pose.position.y = xy
    msg.pose.pose.orientation.w = 1.0
    msg.pose.covariance = [1e-4 if i in (0, 7, 35) else 0.0 for i in range(36)]
    time.sleep(0.5)
    amcl.wait(1)  # the reset's estimate (latched)
    pub.publish(msg)
    time.sleep(0.3)
    trigger.publish(Bool(True))
    amcl.wait(2)
    time.sleep(0.2)
    p = amcl.all[-1].pose.pose
    t = [t.transform for m in tf.all for t in m.transforms if t.child_frame_id == "odom"][-1]
    return {
        "amcl": [p.position.x, p.position.y, p.orientation.z, p.orientation.w],
        "map_to_odom": [t.translation.x, t.translation.y, t.rotation.z, t.rotation.w],
    }


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--goal", type=float, nargs=2, required=True)
    parser.add_argument("--frame", default="map")
    parser.add_argument("--max-steps", type=int, default=600)
    parser.add_argument("--bad-goals", action="store_true")
    parser.add_argument("--initial", type=float, nargs=2, help="an /initialpose (x, y) first")
    args = parser.parse_args()
    rospy.init_node("nav_test_client", anonymous=True, disable_signals=True)
    goals = Kept("/move_base/current_goal", PoseStamped)
    plans = Kept("/plan", Path)
    reached = Kept("/goal_reached", Bool)
    done = Kept("/simulationStepDone", Bool)
    odom = Kept("/odom", Odometry)
    send = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=10, latch=False)
    trigger = rospy.Publisher("/triggerNextStep", Bool, queue_size=10, tcp_nodelay=True)
    end = time.monotonic() + 10
    while (send.get_num_connections() < 1 or trigger.get_num_connections() < 1) and (
        time.monotonic() < end
    ):
        time.sleep(0.02)
    goals.wait(1)
    plans.wait(1)
    time.sleep(0.3)  # let every subscriber connect (done, odom)
    estimates = []
    if args.initial:
        estimates = initial_pose(args.initial, trigger, done)
    for bad in (("base_link", 1.0, 0.0), ("map", 25.0, 0.0), ("odom", 1.95, 0.0)):
        if args.bad_goals:
            send.publish(goal_message(bad[1], bad[2], bad[0]))
            time.sleep(0.25)  # the loop applies each on its own (a queued goal replaces the last)
    send.publish(goal_message(args.goal[0], args.goal[1], args.frame))
    goals.wait(2)
    plans.wait(2)
    steps = 0
    while steps < args.max_steps and not any(m.data for m in reached.all):
        before = len(done.all)
        trigger.publish(Bool(True))
        steps += 1
        end = time.monotonic() + 5
        while len(done.all) == before and time.monotonic() < end:
            time.sleep(0.0005)
        time.sleep(0.002)  # /goal_reached goes out before simulationStepDone; allow for it
    print(
        json.dumps(
            {
                "goals": [
                    [m.header.frame_id, m.pose.position.x, m.pose.position.y] for m in goals.all
                ],
                "plans": [
                    [m.header.frame_id, [[p.pose.position.x, p.pose.position.y] for p in m.poses]]
                    for m in plans.all
                ],
                "reached": [m.data for m in reached.all],
                "steps": steps,
                "odom": [[m.pose.pose.position.x, m.pose.pose.position.y] for m in odom.all],
                "estimates": estimates,
            }
        ),
        flush=True,
    )
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
