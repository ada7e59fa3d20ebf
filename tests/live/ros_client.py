"""External ROS 1 nodes for the live tests: run with Debian's /usr/bin/python3 (real rospy).

Each subcommand prints one JSON line on stdout. ``tutorialloop`` is the tutorial's
``rosBubbleRob2``: forward; for a while after ``sensorTrigger``, back up while turning. What does
not depend on rospy is in ``tests/live_client_support.py``, shared with the ROS 2 client.
"""

import json
import sys
import time
from io import BytesIO
from pathlib import Path

import rospy
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool, Float32, Int32, String
from tf2_msgs.msg import TFMessage

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the shared client parts
import live_client_support as shared  # noqa: E402
from live_client_support import ns  # noqa: E402


class Counter(shared.MessageCounter):
    """Messages of one topic (rospy subscriber): count, latest, all (optional)."""

    def __init__(self, topic, cls, keep=False):
        super().__init__(topic, keep, timeout=5.0)
        self.sub = rospy.Subscriber(topic, cls, self._cb, tcp_nodelay=True, queue_size=None)


class Made:
    """The subscribers and publishers of the subcommand under way (``serve`` drops them after)."""

    def __init__(self):
        self.entities = []
        for name in ("Subscriber", "Publisher"):
            setattr(rospy, name, self._recorded(getattr(rospy, name)))

    def _recorded(self, cls):
        def make(*args, **kwargs):
            entity = cls(*args, **kwargs)
            self.entities.append(entity)
            return entity

        return make

    def drop(self):
        while self.entities:
            self.entities.pop().unregister()


def publisher(topic, cls, latch=False, subscribers=1, timeout=5.0):
    pub = rospy.Publisher(topic, cls, queue_size=100, latch=latch, tcp_nodelay=True)
    end = time.monotonic() + timeout
    while pub.get_num_connections() < subscribers:
        if time.monotonic() > end:
            raise SystemExit(f"nobody subscribed to {topic}")
        time.sleep(0.01)
    return pub


def raw_publisher(topic, cls):
    """A publisher of ``cls``'s type that sends any bytes (to send malformed messages)."""
    raw_cls = type(
        "Raw" + cls.__name__,
        (rospy.AnyMsg,),
        {"_type": cls._type, "_md5sum": cls._md5sum, "_full_text": cls._full_text, "__slots__": ()},
    )
    pub = publisher(topic, raw_cls)

    def send(raw):
        msg = raw_cls()
        msg._buff = raw
        pub.publish(msg)

    return send


def serialized(message):
    buffer = BytesIO()
    message.serialize(buffer)
    return buffer.getvalue()


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


def odom_dict(msg):
    return shared.odom_fields(msg, msg.header.stamp.to_nsec())


def twist(v, w):
    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    return msg


def cmd_odom(args):
    return odom_dict(rospy.wait_for_message(ns(args, "odom"), Odometry, timeout=10))


def cmd_map(args):
    """A late subscriber: the latched /map and /tf_static, then further maps for ``--seconds``."""
    maps = Counter(ns(args, "map"), OccupancyGrid, keep=True)
    # Every latched /tf_static: other robots of the graph (a module's earlier nodes) latch theirs.
    static = Counter("/tf_static", TFMessage, keep=True)
    first = maps.wait(1, timeout=10)
    static.wait(1, timeout=10)
    time.sleep(args.seconds)
    return {
        "first": shared.grid_fields(first, first.header.stamp.to_nsec()),
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
        raw_publisher(args.topic, Twist)(b"\x00" * 8)
    else:
        cls, make = kinds[args.kind]
        publisher(args.topic, cls, latch=True).publish(make(args.value))
    time.sleep(args.linger)
    return {"published": args.topic}


def cmd_drive(args):
    """Publish a twist on cmd_vel at 20 Hz for ``--seconds``; odometry then and ``--idle`` later."""
    odom = Counter(ns(args, "odom"), Odometry)
    pub = publisher(ns(args, "cmd_vel"), Twist)
    return shared.drive(args, lambda v, w: pub.publish(twist(v, w)), odom, odom_dict)


def cmd_sync(args):
    """Trigger one step, then ``n`` more; report /clock before and after."""
    trigger = publisher(ns(args, "triggerNextStep"), Bool)
    done = Counter(ns(args, "simulationStepDone"), Bool)
    clock = Counter("/clock", Clock)
    wait_connected(done.sub)
    wait_connected(clock.sub)
    return shared.sync(
        args, lambda: trigger.publish(Bool(True)), done, clock, lambda m: m.clock.to_nsec()
    )


def cmd_states(args):
    """pause, start, stop, start: the simulationState after each, and /clock while paused."""
    state = Counter(ns(args, "simulationState"), Int32, keep=True)
    clock = Counter("/clock", Clock)
    pubs = {e: publisher(ns(args, f"{e}Simulation"), Bool) for e in ("start", "pause", "stop")}
    return shared.states(args, state, clock, lambda event: pubs[event].publish(Bool(True)))


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

    def wheels(left_speed, right_speed):
        left.publish(Float32(left_speed))
        right.publish(Float32(right_speed))

    triggers = shared.tutorial_loop(args, trig, done, wheels, lambda: trigger.publish(Bool(True)))
    return {"steps": done.count, "collisions": sum(m.data for m in term.all), "triggers": triggers}


def cmd_localize(args):
    """Drive a circle; /amcl_pose and the truth; malformed /initialpose, then a valid one."""
    amcl = Counter(ns(args, "amcl_pose"), PoseWithCovarianceStamped, keep=True)
    truth = Counter(ns(args, "base_pose_ground_truth"), Odometry, keep=True)
    odom = Counter(ns(args, "odom"), Odometry)
    cloud = Counter(ns(args, "particlecloud"), PoseArray)
    tf = Counter("/tf", TFMessage, keep=True)
    static = Counter("/tf_static", TFMessage, keep=True)
    for c in (amcl, truth, cloud, tf):
        wait_connected(c.sub)
    send = raw_publisher(ns(args, "initialpose"), PoseWithCovarianceStamped)
    publisher(ns(args, "cmd_vel"), Twist, latch=True).publish(twist(args.linear, args.angular))
    io = shared.LocalizeIO(
        stamp_ns=lambda stamp: stamp.to_nsec(),
        send_raw=lambda: send(b"\x01" * 9),  # too short for the type
        send_pose=lambda *pose: send(
            serialized(shared.fill_initial_pose(PoseWithCovarianceStamped(), *pose))
        ),
        frame=args.frame_prefix + "map",
    )
    return shared.localize(args, io, amcl, truth, odom, cloud, tf, static)


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
    # The last scan's /clock tick may still be on its way (its own connection).
    with scan.cond:
        scans = list(scan.all)
    last_scan = scans[-1].header.stamp.to_nsec()
    clock.wait_until(lambda m: m.clock.to_nsec() >= last_scan, "the last scan's tick")
    return {
        "before": before,
        "after": after,
        "marks": marks,
        "scan_stamps": [m.header.stamp.to_nsec() for m in scans],
        "scan_rays": len(scans[0].ranges),
        "scan_frame": scans[0].header.frame_id,
        "image_stamps": [m.header.stamp.to_nsec() for m in image.all],
        "sim_times": [m.data for m in sim_time.all],
        "clocks": [m.clock.to_nsec() for m in clock.all],
        "tf_static": [
            [t.header.frame_id, t.child_frame_id] for m in static.all for t in m.transforms
        ],
    }


def main():
    parser, sub = shared.parser(linger=0.3)
    sub.choices["localize"].add_argument("--frame-prefix", default="")
    sub.choices["tutorialloop"].add_argument("--wait-recorder", action="store_true")
    sub.choices["tutorialloop"].add_argument("--node", default="/bubblerob")
    p = sub.add_parser("vrep")
    p.add_argument("--linear", type=float, default=0.6)
    p.add_argument("--angular", type=float, default=0.4)
    p.add_argument("--seconds", type=float, default=1.5)
    args = parser.parse_args()
    rospy.init_node("live_test_client", anonymous=True, disable_signals=True)
    if args.cmd == "serve":
        made = Made()
        shared.serve(parser, lambda a: globals()["cmd_" + a.cmd](a), made.drop)
    else:
        print(json.dumps(globals()["cmd_" + args.cmd](args)), flush=True)
    rospy.signal_shutdown("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
