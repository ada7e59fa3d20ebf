"""External ROS 1 nodes for the live tests: run with Debian's /usr/bin/python3 (real rospy).

Each subcommand prints one JSON line on stdout. ``tutorialloop`` is the tutorial's
``rosBubbleRob2``: forward; for a while after ``sensorTrigger``, back up while turning.
"""

import argparse
import json
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool, Float32, Int32, String
from tf2_msgs.msg import TFMessage


class Counter:
    """Messages of one topic: count, latest, all (optional)."""

    def __init__(self, topic, cls, keep=False):
        self.cond = threading.Condition()
        self.count = 0
        self.latest = None
        self.all = [] if keep else None
        self.sub = rospy.Subscriber(topic, cls, self._cb, tcp_nodelay=True, queue_size=None)

    def _cb(self, msg):
        with self.cond:
            self.count += 1
            self.latest = msg
            if self.all is not None:
                self.all.append(msg)
            self.cond.notify_all()

    def wait(self, count, timeout=5.0):
        end = time.monotonic() + timeout
        with self.cond:
            while self.count < count:
                left = end - time.monotonic()
                if left <= 0:
                    raise SystemExit(
                        f"timeout waiting for message {count} on {self.sub.name}"
                        f" (have {self.count})"
                    )
                self.cond.wait(left)
            return self.latest


def publisher(topic, cls, latch=False, subscribers=1, timeout=5.0):
    pub = rospy.Publisher(topic, cls, queue_size=100, latch=latch, tcp_nodelay=True)
    end = time.monotonic() + timeout
    while pub.get_num_connections() < subscribers:
        if time.monotonic() > end:
            raise SystemExit(f"nobody subscribed to {topic}")
        time.sleep(0.01)
    return pub


def ns(args, name):
    return (args.ns.rstrip("/") + "/" + name) if args.ns else "/" + name


def wait_connected(sub, timeout=5.0):
    """Until ``sub`` is connected to every publisher the master lists for its topic."""
    master = rospy.get_master()
    end = time.monotonic() + timeout
    while True:
        _, _, (published, _, _) = master.getSystemState()
        wanted = sum(len(nodes) for topic, nodes in published if topic == sub.resolved_name)
        if wanted and sub.get_num_connections() >= wanted:
            return
        if time.monotonic() > end:
            raise SystemExit(f"not connected to every publisher of {sub.name}")
        time.sleep(0.01)


def cmd_odom(args):
    return odom_dict(rospy.wait_for_message(ns(args, "odom"), Odometry, timeout=10))


def odom_dict(msg):
    p, q, t = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist
    import math

    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    return {
        "x": p.x,
        "y": p.y,
        "yaw": yaw,
        "vx": t.linear.x,
        "wz": t.angular.z,
        "stamp": msg.header.stamp.to_nsec(),
    }


def map_dict(msg):
    i, o = msg.info, msg.info.origin
    return {
        "stamp": msg.header.stamp.to_nsec(),
        "frame_id": msg.header.frame_id,
        "resolution": i.resolution,
        "width": i.width,
        "height": i.height,
        "origin": [o.position.x, o.position.y, o.orientation.w],
        "data": list(msg.data),
    }


def cmd_map(args):
    """A late subscriber: the latched /map and /tf_static, then further maps for ``--seconds``."""
    maps = Counter(ns(args, "map"), OccupancyGrid, keep=True)
    # Every latched /tf_static: other robots of the graph (a module's earlier nodes) latch theirs.
    static = Counter("/tf_static", TFMessage, keep=True)
    first = maps.wait(1, timeout=10)
    static.wait(1, timeout=10)
    time.sleep(args.seconds)
    return {
        "first": map_dict(first),
        "stamps": [m.header.stamp.to_nsec() for m in maps.all],
        "distinct": len({bytes(bytearray(m.data)) for m in maps.all}),
        "tf_static": [
            [t.header.frame_id, t.child_frame_id] for msg in static.all for t in msg.transforms
        ],
        "latching": (getattr(first, "_connection_header", None) or {}).get("latching"),
    }


def cmd_count(args):
    """How many messages each topic gets in ``--seconds``."""
    counts = dict.fromkeys(args.topics, 0)

    def make(topic):
        return lambda _: counts.__setitem__(topic, counts[topic] + 1)

    subs = {t: rospy.Subscriber(t, rospy.AnyMsg, make(t)) for t in args.topics}
    time.sleep(args.seconds)
    for s in subs.values():
        s.unregister()
    return counts


def cmd_pub(args):
    kinds = {
        "bool": (Bool, lambda v: Bool(v == "true")),
        "float32": (Float32, lambda v: Float32(float(v))),
        "string": (String, lambda v: String(v)),
        "twist": (Twist, lambda v: twist(*map(float, v.split(",")))),
    }
    if args.kind == "badtwist":  # 8 bytes, declared as a Twist (48 bytes)
        cls = type(
            "BadTwist",
            (rospy.AnyMsg,),
            {
                "_type": Twist._type,
                "_md5sum": Twist._md5sum,
                "_full_text": Twist._full_text,
                "__slots__": (),
            },
        )
        msg = cls()
        msg._buff = b"\x00" * 8
    else:
        cls, make = kinds[args.kind]
        msg = make(args.value)
    pub = publisher(args.topic, cls, latch=True)
    pub.publish(msg)
    time.sleep(args.linger)
    return {"published": args.topic}


def twist(v, w):
    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    return msg


def cmd_drive(args):
    """Publish a twist on cmd_vel at 20 Hz for ``--seconds``; odometry then and ``--idle`` later."""
    odom = Counter(ns(args, "odom"), Odometry)
    pub = publisher(ns(args, "cmd_vel"), Twist)
    end = time.monotonic() + args.seconds
    rate = rospy.Rate(20)
    while time.monotonic() < end:
        pub.publish(twist(args.linear, args.angular))
        rate.sleep()
    result = {"moving": odom_dict(odom.wait(1))}
    if args.idle:
        time.sleep(args.idle)
        result["idle"] = odom_dict(odom.latest)
    return result


def cmd_sync(args):
    """Trigger one step, then ``n`` more; report /clock before and after."""
    trigger = publisher(ns(args, "triggerNextStep"), Bool)
    done = Counter(ns(args, "simulationStepDone"), Bool)
    clock = Counter("/clock", Clock)
    wait_connected(done.sub)
    wait_connected(clock.sub)
    trigger.publish(Bool(True))
    done.wait(1)
    t0 = clock.wait(1).clock.to_nsec()
    c0 = clock.count
    for _ in range(args.n):
        trigger.publish(Bool(True))
    done.wait(1 + args.n, timeout=20)
    clock.wait(c0 + args.n)
    t1 = clock.latest.clock.to_nsec()
    time.sleep(args.settle)
    return {"t0": t0, "t1": t1, "done": done.count - 1, "clocks": clock.count - c0}


def cmd_states(args):
    """pause, start, stop, start: the simulationState after each, and /clock while paused."""
    state = Counter(ns(args, "simulationState"), Int32, keep=True)
    clock = Counter("/clock", Clock)
    pubs = {e: publisher(ns(args, f"{e}Simulation"), Bool) for e in ("start", "pause", "stop")}
    state.wait(1)
    seen = [state.latest.data]
    paused_clocks = None
    for event in ("pause", "start", "stop", "start"):
        before = state.count
        pubs[event].publish(Bool(True))
        state.wait(before + 1)
        seen.append(state.latest.data)
        if event == "pause":
            time.sleep(0.2)
            c = clock.count
            time.sleep(args.pause_seconds)
            paused_clocks = clock.count - c
    time.sleep(0.5)
    return {"states": seen, "paused_clocks": paused_clocks, "clocks": clock.count}


def wait_recorder(node, timeout=20.0):
    """Until ``rosbag record`` is connected to every topic of ``node`` that it subscribes to."""
    import xmlrpc.client

    master = rospy.get_master()
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        _, _, (_, subscribed, _) = master.getSystemState()
        wanted = {t for t, nodes in subscribed if any(n.startswith("/record") for n in nodes)}
        _, _, uri = master.lookupNode(node)
        _, _, bus = xmlrpc.client.ServerProxy(uri).getBusInfo(rospy.get_name())
        connected = {c[4] for c in bus if c[2] == "o" and c[1].startswith("/record") and c[5]}
        if wanted and wanted <= connected:
            return
        time.sleep(0.05)
    raise SystemExit("rosbag record did not connect")


def cmd_tutorialloop(args):
    """rosBubbleRob2 in sync mode: forward; after sensorTrigger back up turning for a while."""
    trig = Counter(ns(args, "sensorTrigger"), Bool)
    done = Counter(ns(args, "simulationStepDone"), Bool)
    term = Counter(ns(args, "terminated"), Bool, keep=True)
    left = publisher(ns(args, "leftMotorSpeed"), Float32)
    right = publisher(ns(args, "rightMotorSpeed"), Float32)
    trigger = publisher(ns(args, "triggerNextStep"), Bool)
    start = publisher(ns(args, "startSimulation"), Bool)
    for c in (trig, done, term):
        wait_connected(c.sub)
    if args.wait_recorder:
        wait_recorder(args.node)
    start.publish(Bool(True))
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
        left.publish(Float32(wanted[0]))  # every step, as the tutorial's node does (and the
        right.publish(Float32(wanted[1]))  # node's watchdog wants)
        if wanted != command:
            command = wanted
            time.sleep(0.005)  # commands and trigger travel on different connections
        trigger.publish(Bool(True))
        done.wait(k + 1)
        trig.wait(k + 2)
    time.sleep(args.settle)
    return {"steps": done.count, "collisions": sum(m.data for m in term.all), "triggers": triggers}


def pose_tuple(stamp, pose):
    import math

    p, q = pose.position, pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    return [stamp.to_nsec(), p.x, p.y, yaw]


def raw_pose_publisher(topic):
    """A publisher of PoseWithCovarianceStamped that sends any bytes (to send malformed ones)."""
    from io import BytesIO

    from geometry_msgs.msg import PoseWithCovarianceStamped as Pwcs

    cls = type(
        "RawPose",
        (rospy.AnyMsg,),
        {
            "_type": Pwcs._type,
            "_md5sum": Pwcs._md5sum,
            "_full_text": Pwcs._full_text,
            "__slots__": (),
        },
    )
    pub = publisher(topic, cls)

    def send(message=None, raw=None):
        if message is not None:
            buffer = BytesIO()
            message.serialize(buffer)
            raw = buffer.getvalue()
        msg = cls()
        msg._buff = raw
        pub.publish(msg)

    return send


def initial_pose(frame, x, y, yaw, variance=0.01):
    import math

    from geometry_msgs.msg import PoseWithCovarianceStamped

    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = frame
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = covariance[35] = variance
    msg.pose.covariance = covariance
    return msg


def cmd_localize(args):
    """Drive a circle; /amcl_pose and the truth; malformed /initialpose, then a valid one."""
    from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped

    amcl = Counter(ns(args, "amcl_pose"), PoseWithCovarianceStamped, keep=True)
    truth = Counter(ns(args, "base_pose_ground_truth"), Odometry, keep=True)
    odom = Counter(ns(args, "odom"), Odometry)
    cloud = Counter(ns(args, "particlecloud"), PoseArray)
    tf = Counter("/tf", TFMessage, keep=True)
    static = Counter("/tf_static", TFMessage, keep=True)
    for c in (amcl, truth, cloud, tf):
        wait_connected(c.sub)
    send = raw_pose_publisher(ns(args, "initialpose"))
    publisher(ns(args, "cmd_vel"), Twist, latch=True).publish(twist(args.linear, args.angular))
    # Simulated seconds of driving, however fast the node runs on a loaded machine.
    start = truth.wait(truth.count + 1).header.stamp.to_nsec()
    deadline = time.monotonic() + 60.0
    while truth.latest.header.stamp.to_nsec() - start < args.sim_seconds * 1e9:
        if time.monotonic() > deadline:
            raise SystemExit("the node did not simulate --sim-seconds within 60 s")
        time.sleep(0.05)
    tracked = [pose_tuple(m.header.stamp, m.pose.pose) for m in list(amcl.all)]
    truths = [pose_tuple(m.header.stamp, m.pose.pose) for m in list(truth.all)]
    last_odom = pose_tuple(odom.latest.header.stamp, odom.latest.pose.pose)
    frame = args.frame_prefix + "map"
    send(raw=b"\x01" * 9)  # too short for the type
    send(initial_pose(frame, float("nan"), 0.0, 0.0))
    send(initial_pose("base_link", 0.0, 0.0, 0.0))
    time.sleep(1.0)
    after_bad = amcl.count
    _, x, y, yaw = pose_tuple(truth.latest.header.stamp, truth.latest.pose.pose)
    target = [x + args.offset, y, yaw]
    send(initial_pose(frame, *target))
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
        "tf_map_odom": sum(1 for m in tf.all for t in m.transforms if t.header.frame_id == frame),
        "tf_static": [
            [t.header.frame_id, t.child_frame_id] for m in static.all for t in m.transforms
        ],
        "target": target,
        "after": [pose_tuple(m.header.stamp, m.pose.pose) for m in list(amcl.all)[after_bad:]],
    }


def cmd_vrep(args):
    """The tutorial's Pioneer interface: drive on /vrep/cmd_vel while recording /vrep/scan, /simTime
    and /vrep/image stamps; then both switches off for ``--seconds``, then on again."""
    from sensor_msgs.msg import Image, LaserScan

    scan = Counter("/vrep/scan", LaserScan, keep=True)
    image = Counter("/vrep/image", Image, keep=True)
    sim_time = Counter("/simTime", Float32, keep=True)
    clock = Counter("/clock", Clock, keep=True)
    odom = Counter("/odom", Odometry)
    static = Counter("/tf_static", TFMessage, keep=True)
    for c in (scan, image, sim_time, clock, odom):
        wait_connected(c.sub)
    switches = {s: publisher(f"/vrep/{s}_switch", Bool, latch=True) for s in ("laser", "camera")}
    drive = publisher("/vrep/cmd_vel", Twist)
    before = odom_dict(odom.wait(odom.count + 1))
    marks = {"start": (scan.count, image.count, sim_time.count)}
    end, rate = time.monotonic() + args.seconds, rospy.Rate(20)
    while time.monotonic() < end:
        drive.publish(twist(args.linear, args.angular))
        rate.sleep()
    after = odom_dict(odom.wait(odom.count + 1))
    for phase, on in (("off", False), ("on", True)):
        for pub in switches.values():
            pub.publish(Bool(on))
        time.sleep(0.5)  # the switches take effect at the node's next step
        marks[phase] = (scan.count, image.count, sim_time.count)
        time.sleep(args.seconds)
        marks[phase + "_end"] = (scan.count, image.count, sim_time.count)
    return {
        "before": before,
        "after": after,
        "marks": marks,
        "scan_stamps": [m.header.stamp.to_nsec() for m in scan.all],
        "scan_rays": len(scan.all[0].ranges),
        "scan_frame": scan.all[0].header.frame_id,
        "image_stamps": [m.header.stamp.to_nsec() for m in image.all],
        "sim_times": [m.data for m in sim_time.all],
        "clocks": [m.clock.to_nsec() for m in clock.all],
        "tf_static": [
            [t.header.frame_id, t.child_frame_id] for m in static.all for t in m.transforms
        ],
    }


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--ns", default="")
    sub = parser.add_subparsers(dest="cmd", required=True)
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
    p.add_argument("--linger", type=float, default=0.3)
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
    p.add_argument("--frame-prefix", default="")
    p = sub.add_parser("vrep")
    p.add_argument("--linear", type=float, default=0.6)
    p.add_argument("--angular", type=float, default=0.4)
    p.add_argument("--seconds", type=float, default=1.5)
    p = sub.add_parser("tutorialloop")
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--forward", type=float, default=8.0)
    p.add_argument("--speed", type=float, default=10.0)
    p.add_argument("--back-steps", type=int, default=30)
    p.add_argument("--settle", type=float, default=1.0)
    p.add_argument("--wait-recorder", action="store_true")
    p.add_argument("--node", default="/bubblerob")
    args = parser.parse_args()
    rospy.init_node("live_test_client", anonymous=True, disable_signals=True)
    result = globals()["cmd_" + args.cmd](args)
    print(json.dumps(result), flush=True)
    rospy.signal_shutdown("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
