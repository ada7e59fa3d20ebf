"""A Nav2-style user of ``bubblerob node --ros 2 --env BubbleRobNav-v0 --sync``: real rclpy.

Run with .venv-ros2's python. Sends a goal in frame ``base_link`` (refused), then ``--goal X Y``
in ``--frame`` on ``/move_base_simple/goal``, and triggers steps until ``/goal_reached`` (latched,
transient local) says True, at most ``--max-steps``. Prints one JSON line: the goals and plans
seen, the ``/goal_reached`` values, the steps triggered and every ``/odom`` position.
"""

import argparse
import json
import os
import threading
import time

import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Bool

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--goal", type=float, nargs=2, required=True)
    parser.add_argument("--frame", default="map")
    parser.add_argument("--max-steps", type=int, default=600)
    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node("nav_test_client")
    got = {"goals": [], "plans": [], "reached": [], "done": 0, "odom": []}
    lock = threading.Lock()

    def keep(key, convert):
        def callback(msg):
            with lock:
                got[key].append(convert(msg))

        return callback

    def pose_xy(pose):
        return [pose.position.x, pose.position.y]

    node.create_subscription(
        PoseStamped,
        "/move_base/current_goal",
        keep("goals", lambda m: [m.header.frame_id, *pose_xy(m.pose)]),
        LATCHED,
    )
    node.create_subscription(
        Path,
        "/plan",
        keep("plans", lambda m: [m.header.frame_id, [pose_xy(p.pose) for p in m.poses]]),
        LATCHED,
    )
    node.create_subscription(Bool, "/goal_reached", keep("reached", lambda m: m.data), 100)
    node.create_subscription(Odometry, "/odom", keep("odom", lambda m: pose_xy(m.pose.pose)), 100)

    def done(_msg):
        with lock:
            got["done"] += 1

    node.create_subscription(Bool, "/simulationStepDone", done, 100)
    send = node.create_publisher(PoseStamped, "/move_base_simple/goal", 10)
    trigger = node.create_publisher(Bool, "/triggerNextStep", 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()

    def wait(condition, timeout=20.0):
        end = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > end:
                raise SystemExit(f"timed out: {got}")
            time.sleep(0.005)

    wait(lambda: send.get_subscription_count() and trigger.get_subscription_count())
    wait(lambda: got["goals"] and got["plans"])

    def goal(x, y, frame):
        msg = PoseStamped()
        msg.header.frame_id = frame
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.w = 1.0
        return msg

    time.sleep(0.5)  # the node's subscriptions to our publishers are matched both ways
    send.publish(goal(1.0, 0.0, "base_link"))
    time.sleep(0.3)
    send.publish(goal(args.goal[0], args.goal[1], args.frame))
    wait(lambda: len(got["goals"]) >= 2 and len(got["plans"]) >= 2)
    steps = 0
    while steps < args.max_steps and not any(got["reached"]):
        before = got["done"]
        trigger.publish(Bool(data=True))
        steps += 1
        wait(lambda before=before: got["done"] > before, timeout=5.0)
        time.sleep(0.003)  # /goal_reached goes out before simulationStepDone; allow for it
    with lock:
        print(json.dumps({**got, "steps": steps}), flush=True)
    os._exit(0)  # no teardown: the executor's thread spinning at exit would abort the process


if __name__ == "__main__":
    main()
