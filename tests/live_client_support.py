"""What the live tests' ROS 1 and ROS 2 clients share: standard library only.

``tests/live/ros_client.py`` runs on Debian's /usr/bin/python3 with rospy, and
``tests/live2/ros2_client.py`` on ``.venv-ros2``'s python with rclpy; both put tests/ on
``sys.path`` and import this module. Here: counting messages, the subcommands' arguments and the
parts of ``sync``, ``states``, ``drive``, ``tutorialloop`` and ``localize`` that do not depend on
the client library, which each client passes in as small functions (publish this, stamp of that).

``serve`` runs many subcommands in one client process (the tests' ``ClientServer``): a client
library's start and its discovery of the graph are paid once per test session, not per call.
"""

import argparse
import json
import math
import sys
import threading
import time
import traceback

RESULT = "CLIENT-RESULT "
"""How ``serve`` marks its answer lines on stdout (anything else there is the library's)."""


class MessageCounter:
    """Messages of one topic: count, latest, all (optional). Subclasses subscribe to ``_cb``."""

    def __init__(self, topic, keep=False, timeout=10.0):
        self.cond = threading.Condition()
        self.topic = topic
        self.count = 0
        self.latest = None
        self.all = [] if keep else None
        self.timeout = timeout

    def _cb(self, msg):
        with self.cond:
            self.count += 1
            self.latest = msg
            if self.all is not None:
                self.all.append(msg)
            self.cond.notify_all()

    def wait(self, count, timeout=None):
        """The latest message once ``count`` have come; exits the client after ``timeout``."""
        return self._wait_for(
            lambda: self.count >= count,
            lambda: f"message {count} on {self.topic} (have {self.count})",
            timeout,
        )

    def wait_until(self, done, what, timeout=None):
        """The latest message once ``done(latest)`` holds; exits the client after ``timeout``.

        For a message of another topic published at the same step: topics travel on their own
        connections, so one topic's message of step k can arrive before another's."""
        return self._wait_for(
            lambda: self.latest is not None and done(self.latest),
            lambda: f"{what} on {self.topic}",
            timeout,
        )

    def _wait_for(self, ready, what, timeout):
        """The latest message once ``ready()``; else ``SystemExit`` naming ``what()``."""
        end = time.monotonic() + (self.timeout if timeout is None else timeout)
        with self.cond:
            while not ready():
                left = end - time.monotonic()
                if left <= 0:
                    raise SystemExit(f"timeout waiting for {what()}")
                self.cond.wait(left)
            return self.latest


def ns(args, name):
    """``name`` under the client's ``--ns`` (absolute)."""
    return (args.ns.rstrip("/") + "/" + name) if args.ns else "/" + name


def yaw_of(q):
    """The yaw of a quaternion message."""
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def pose_list(stamp_ns, pose):
    """``[stamp_ns, x, y, yaw]`` of a ``geometry_msgs/Pose``."""
    return [stamp_ns, pose.position.x, pose.position.y, yaw_of(pose.orientation)]


def odom_fields(msg, stamp_ns):
    """What the tests read of an ``Odometry``: pose in the plane, velocities, stamp."""
    p, t = msg.pose.pose.position, msg.twist.twist
    return {
        "x": p.x,
        "y": p.y,
        "yaw": yaw_of(msg.pose.pose.orientation),
        "vx": t.linear.x,
        "wz": t.angular.z,
        "stamp": stamp_ns,
    }


def grid_fields(msg, stamp_ns):
    """An ``OccupancyGrid`` as JSON: header, geometry and cells."""
    i, o = msg.info, msg.info.origin
    return {
        "stamp": stamp_ns,
        "frame_id": msg.header.frame_id,
        "resolution": i.resolution,
        "width": i.width,
        "height": i.height,
        "origin": [o.position.x, o.position.y, o.orientation.w],
        "data": list(msg.data),
    }


def fill_initial_pose(msg, frame, x, y, yaw, variance=0.01):
    """Fill a ``PoseWithCovarianceStamped`` as RViz's "2D Pose Estimate" does; ``msg``."""
    msg.header.frame_id = frame
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = covariance[35] = variance
    msg.pose.covariance = covariance
    return msg


def drive(args, publish_twist, odom, odom_dict):
    """Publish a twist at 20 Hz for ``--seconds``; odometry then and ``--idle`` later."""
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        publish_twist(args.linear, args.angular)
        time.sleep(0.05)
    result = {"moving": odom_dict(odom.wait(1))}
    if args.idle:
        time.sleep(args.idle)
        result["idle"] = odom_dict(odom.latest)
    return result


def sync(args, trigger, done, clock, clock_ns):
    """Trigger one step, then ``n`` more; /clock after each part (``trigger()`` publishes).

    Each stamp is read once ``--settle`` has passed with no trigger, so it is the latest step's:
    /clock and simulationStepDone come on separate connections (a step's /clock may still be on
    its way when its "done" is here), and a client that subscribes as the node starts may also get
    the node's first frame (its reset, published just after "ready"), which is no step's.
    """
    trigger()
    done.wait(1)
    clock.wait(1)
    time.sleep(args.settle)  # a node in sync mode publishes nothing more until triggered
    t0, c0 = clock_ns(clock.latest), clock.count
    for _ in range(args.n):
        trigger()
    done.wait(1 + args.n, timeout=20)
    clock.wait(c0 + args.n)
    time.sleep(args.settle)
    t1 = clock_ns(clock.latest)
    return {"t0": t0, "t1": t1, "done": done.count - 1, "clocks": clock.count - c0}


def states(args, state, clock, publish_event):
    """pause, start, stop, start: the simulationState after each, and /clock while paused."""
    state.wait(1)
    seen = [state.latest.data]
    paused_clocks = None
    for event in ("pause", "start", "stop", "start"):
        before = state.count
        publish_event(event)
        state.wait(before + 1)
        seen.append(state.latest.data)
        if event == "pause":
            time.sleep(0.2)
            c = clock.count
            time.sleep(args.pause_seconds)
            paused_clocks = clock.count - c
    time.sleep(0.5)
    return {"states": seen, "paused_clocks": paused_clocks, "clocks": clock.count}


def tutorial_loop(args, trig, done, publish_wheels, trigger):
    """rosBubbleRob2's loop in sync mode, after ``startSimulation``; how often it was triggered.

    Forward; for ``--back-steps`` steps after ``sensorTrigger``, back up while turning. Wheel
    speeds go out every step, as the tutorial's node does (and the node's watchdog wants).
    """
    trig.wait(1)
    back_steps, command, triggers = 0, None, 0
    for k in range(args.steps):
        if trig.latest.data:
            back_steps = args.back_steps
            triggers += 1
        if back_steps > 0:
            wanted = (-args.speed / 2, -args.speed / 4)
            back_steps -= 1
        else:
            wanted = (args.forward, args.forward)
        publish_wheels(*wanted)
        if wanted != command:
            command = wanted
            time.sleep(0.005)  # commands and trigger travel on different connections
        trigger()
        done.wait(k + 1)
        trig.wait(k + 2)
    time.sleep(args.settle)
    return triggers


class LocalizeIO:
    """What ``localize`` needs of a client library, passed in by each client."""

    def __init__(self, stamp_ns, send_raw, send_pose, frame):
        self.stamp_ns = stamp_ns
        """Nanoseconds of a header stamp."""
        self.send_raw = send_raw
        """Publish bytes on ``/initialpose`` that are too short for its type."""
        self.send_pose = send_pose
        """Publish an initial pose ``(frame, x, y, yaw)``."""
        self.frame = frame
        """The map frame, as the node names it."""


def localize(args, io, amcl, truth, odom, cloud, tf, static):
    """Drive (the caller's latched ``cmd_vel``) ``--sim-seconds`` of simulated time; then send
    three malformed ``/initialpose`` messages and a valid one ``--offset`` m off the truth."""

    def stamped(msg, pose):
        return pose_list(io.stamp_ns(msg.header.stamp), pose)

    # Simulated seconds of driving, however fast the node runs on a loaded machine.
    start = io.stamp_ns(truth.wait(truth.count + 1).header.stamp)
    deadline = time.monotonic() + 60.0
    while io.stamp_ns(truth.latest.header.stamp) - start < args.sim_seconds * 1e9:
        if time.monotonic() > deadline:
            raise SystemExit("the node did not simulate --sim-seconds within 60 s")
        time.sleep(0.05)
    last_odom = stamped(odom.latest, odom.latest.pose.pose)
    # The truth of the last /odom's step may still be on its way (its own connection).
    truth.wait_until(
        lambda m: io.stamp_ns(m.header.stamp) >= last_odom[0], "the truth of the last /odom"
    )
    with amcl.cond, truth.cond:
        tracked = [stamped(m, m.pose.pose) for m in amcl.all]
        truths = [stamped(m, m.pose.pose) for m in truth.all]
    io.send_raw()
    io.send_pose(io.frame, float("nan"), 0.0, 0.0)
    io.send_pose("base_link", 0.0, 0.0, 0.0)
    time.sleep(1.0)
    after_bad = amcl.count
    _, x, y, yaw = stamped(truth.latest, truth.latest.pose.pose)
    target = [x + args.offset, y, yaw]
    io.send_pose(io.frame, *target)
    amcl.wait(after_bad + 1)
    time.sleep(1.0)  # poses published before the node took the initial pose come first
    return {
        "tracked": tracked,
        "truth": truths,
        "odom_last": last_odom,
        "clouds": cloud.count,
        "cloud_size": len(cloud.latest.poses),
        "cloud_frame": cloud.latest.header.frame_id,
        "amcl_frame": amcl.all[0].header.frame_id,
        "amcl_covariance": list(amcl.all[-1].pose.covariance),
        "tf_map_odom": sum(
            1 for m in tf.all for t in m.transforms if t.header.frame_id == io.frame
        ),
        "tf_static": [
            [t.header.frame_id, t.child_frame_id] for m in static.all for t in m.transforms
        ],
        "target": target,
        "after": [stamped(m, m.pose.pose) for m in list(amcl.all)[after_bad:]],
    }


def parser(linger):
    """The parser and its subcommands (``add_subparsers``' action) with what both clients have;
    ``pub --linger`` defaults to ``linger``. Each client adds its own arguments and subcommands."""
    top = argparse.ArgumentParser()
    top.add_argument("--ns", default="")
    sub = top.add_subparsers(dest="cmd", required=True)
    sub.add_parser("odom")
    p = sub.add_parser("map")
    p.add_argument("--seconds", type=float, default=0.0)
    p = sub.add_parser("count")
    p.add_argument("topics", nargs="+")
    p.add_argument("--seconds", type=float, default=1.0)
    p = sub.add_parser("pub")
    p.add_argument("topic")
    p.add_argument("kind")
    p.add_argument("value", nargs="?", default="")
    p.add_argument("--linger", type=float, default=linger)
    p = sub.add_parser("drive")
    p.add_argument("--linear", type=float, default=0.0)
    p.add_argument("--angular", type=float, default=0.0)
    p.add_argument("--seconds", type=float, default=1.0)
    p.add_argument("--idle", type=float, default=0.0)
    p = sub.add_parser("sync")
    p.add_argument("--n", type=int, default=20)
    p.add_argument("--settle", type=float, default=0.5)
    p = sub.add_parser("states")
    p.add_argument("--pause-seconds", type=float, default=0.5)
    p = sub.add_parser("localize")
    p.add_argument("--linear", type=float, default=0.28)
    p.add_argument("--angular", type=float, default=0.2)
    p.add_argument("--sim-seconds", type=float, default=17.0)
    p.add_argument("--offset", type=float, default=0.5)
    p = sub.add_parser("tutorialloop")
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--forward", type=float, default=8.0)
    p.add_argument("--speed", type=float, default=10.0)
    p.add_argument("--back-steps", type=int, default=30)
    p.add_argument("--settle", type=float, default=1.0)
    sub.add_parser("serve", help="run subcommands read from stdin (see serve())")
    return top, sub


def serve(parser, run, drop_made):
    """Subcommands read from stdin, one JSON list of arguments a line, until end of input.

    Each answer is one ``RESULT`` line: ``{"ok": result}``, or ``{"error": why}`` where a one-shot
    client would have exited non-zero. ``drop_made()`` then removes the subscriptions and
    publishers the subcommand made, as a one-shot client's exit does: nothing it latched or
    listened to outlives it.
    """
    for line in sys.stdin:
        try:
            answer = {"ok": run(parser.parse_args(json.loads(line)))}
        except SystemExit as stop:  # the subcommands' timeouts; argparse's refusals
            answer = {"error": f"exit {stop.code}"}
        except Exception:  # noqa: BLE001 - reported to the test, which fails on it
            answer = {"error": traceback.format_exc()}
        try:
            drop_made()
        except Exception:  # noqa: BLE001
            answer.setdefault("error", "dropping its subscriptions failed")
            answer["error"] += "\n" + traceback.format_exc()
        print(RESULT + json.dumps(answer), flush=True)
