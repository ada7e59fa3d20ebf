"""External ROS 2 nodes for the live tests: run with .venv-ros2's python (real rclpy, Jazzy).

Written as a ROS 2 user writes them: ``rclpy`` subscriptions and publishers with the message
classes, ``qos_profile_sensor_data`` for sensors, ``use_sim_time`` for the simulated clock. Each
subcommand prints one JSON line on stdout. ``tutorialloop`` is the tutorial's ``rosBubbleRob2``:
forward; for a while after ``sensorTrigger``, back up while turning. What does not depend on
rclpy is in ``tests/live_client_support.py``, shared with the ROS 1 client.
"""

import json
import sys
import threading
import time
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, LaserScan, Range
from std_msgs.msg import Bool, Float32, Float64MultiArray, Int32, String
from tf2_msgs.msg import TFMessage

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the shared client parts
import live_client_support as shared  # noqa: E402
from live_client_support import ns  # noqa: E402

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SENSOR_TYPES = (LaserScan, Range, Image, CameraInfo)
RAW_TOPICS = {
    "/odom": Odometry,
    "/tf": TFMessage,
    "/clock": Clock,
    "/sensorTrigger": Bool,
    "/terminated": Bool,
    "/simulationTime": Float32,
    "/bubblerob/action": Float64MultiArray,
}
"""Reliable topics whose every message ``tutorialloop --raw`` keeps as received (CDR bytes)."""


class Counter(shared.MessageCounter):
    """Messages of one topic (rclpy subscription): count, latest, all (optional)."""

    def __init__(self, node, topic, cls, keep=False, qos=None):
        super().__init__(topic, keep, timeout=10.0)
        if qos is None:
            qos = qos_profile_sensor_data if cls in SENSOR_TYPES else 100
        self.sub = node.create_subscription(cls, topic, self._cb, qos)


class Made:
    """The subscriptions and publishers of the subcommand under way (``serve`` drops them after)."""

    def __init__(self, node):
        self.entities = []
        subscribe, advertise = node.create_subscription, node.create_publisher
        node.create_subscription = self._recorded(subscribe, node.destroy_subscription)
        node.create_publisher = self._recorded(advertise, node.destroy_publisher)

    def _recorded(self, create, destroy):
        def make(*args, **kwargs):
            entity = create(*args, **kwargs)
            self.entities.append((entity, destroy))
            return entity

        return make

    def drop(self):
        while self.entities:
            entity, destroy = self.entities.pop()
            destroy(entity)


def wait_until(predicate, timeout, what):
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise SystemExit(f"timeout: {what}")
        time.sleep(0.01)


def publisher(node, topic, cls, depth=100, latched=False, timeout=10.0):
    """A publisher, once the node's subscription has matched it."""
    pub = node.create_publisher(cls, topic, LATCHED if latched else depth)
    wait_until(lambda: pub.get_subscription_count() > 0, timeout, f"nobody subscribed {topic}")
    return pub


def matched(node, counter, timeout=10.0):
    """Until ``counter``'s topic has a publisher (and discovery has settled)."""
    wait_until(lambda: node.count_publishers(counter.topic) > 0, timeout, counter.topic)
    time.sleep(0.3)


def stamp_ns(t):
    return t.sec * 1_000_000_000 + t.nanosec


def odom_dict(msg):
    fields = shared.odom_fields(msg, stamp_ns(msg.header.stamp))
    fields.update(
        w=msg.pose.pose.orientation.w,
        frame_id=msg.header.frame_id,
        child_frame_id=msg.child_frame_id,
    )
    return fields


def qos_of(node, topic):
    infos = node.get_publishers_info_by_topic(topic)
    return [[i.qos_profile.reliability.name, i.qos_profile.durability.name] for i in infos]


def cmd_echo(node, args):
    """One message of each sensor topic, as ``ros2 topic echo`` would show them; QoS; sim time."""
    out = {}
    scan = Counter(node, ns(args, "scan"), LaserScan)
    odom = Counter(node, ns(args, "odom"), Odometry)
    clock = Counter(node, "/clock", Clock)
    tf = Counter(node, "/tf", TFMessage)
    static = Counter(node, "/tf_static", TFMessage, keep=True, qos=LATCHED)
    cams = [Counter(node, ns(args, "camera/image_raw"), Image)] if args.camera else []
    m = scan.wait(1)
    out["scan"] = {
        "frame_id": m.header.frame_id,
        "ranges": len(m.ranges),
        "range_max": m.range_max,
        "angle_increment": m.angle_increment,
    }
    out["odom"] = odom_dict(odom.wait(1))
    m = tf.wait(1)
    out["tf"] = [[t.header.frame_id, t.child_frame_id] for t in m.transforms]
    static.wait(1)
    out["tf_static"] = sorted(
        [t.header.frame_id, t.child_frame_id] for msg in static.all for t in msg.transforms
    )
    if cams:
        m = cams[0].wait(1)
        out["image"] = {"encoding": m.encoding, "step": m.step, "width": m.width}
    # use_sim_time: the node's clock follows /clock
    clock.wait(clock.count + 2)
    time.sleep(0.2)
    with clock.cond:
        last = stamp_ns(clock.latest.clock)
        now = node.get_clock().now().nanoseconds
    out["clock"] = last
    out["sim_now"] = now
    out["clock_type"] = node.get_clock().clock_type.name
    out["qos"] = {
        t: qos_of(node, t)
        for t in (ns(args, "scan"), ns(args, "odom"), "/tf", "/tf_static", "/clock")
    }
    out["type_hash"] = {
        t: [str(i.topic_type_hash) for i in node.get_publishers_info_by_topic(t)]
        for t in ("/tf", "/tf_static", ns(args, "odom"))
    }
    # a subscription with the default (reliable) QoS does not match a sensor-data publisher
    reliable = Counter(node, ns(args, "scan"), LaserScan, qos=10)
    time.sleep(1.0)
    out["reliable_scan"] = reliable.count
    return out


def cmd_map(node, args):
    """A late transient-local subscriber: the latched /map and /tf_static, then ``--seconds``."""
    maps = Counter(node, ns(args, "map"), OccupancyGrid, keep=True, qos=LATCHED)
    static = Counter(node, "/tf_static", TFMessage, keep=True, qos=LATCHED)
    first = maps.wait(1, timeout=20)
    static.wait(1, timeout=20)
    time.sleep(args.seconds)
    return {
        "first": shared.grid_fields(first, stamp_ns(first.header.stamp)),
        "stamps": [stamp_ns(m.header.stamp) for m in maps.all],
        "distinct": len({bytes(bytearray(m.data)) for m in maps.all}),
        "tf_static": sorted(
            [t.header.frame_id, t.child_frame_id] for msg in static.all for t in msg.transforms
        ),
        "qos": qos_of(node, ns(args, "map")),
    }


def cmd_odom(node, args):
    return odom_dict(Counter(node, ns(args, "odom"), Odometry).wait(1))


def cmd_count(node, args):
    """How many messages each topic gets in ``--seconds``."""
    kinds = {"scan": LaserScan, "image_raw": Image, "camera_info": CameraInfo, "odom": Odometry}
    counters = {t: Counter(node, t, kinds[t.rsplit("/", 1)[-1]]) for t in args.topics}
    for c in counters.values():
        matched(node, c)
    start = {t: c.count for t, c in counters.items()}
    time.sleep(args.seconds)
    return {t: c.count - start[t] for t, c in counters.items()}


def cmd_pub(node, args):
    kinds = {
        "bool": (Bool, lambda v: Bool(data=v == "true")),
        "float32": (Float32, lambda v: Float32(data=float(v))),
        "string": (String, lambda v: String(data=v)),
        "twist": (Twist, lambda v: twist(*map(float, v.split(",")))),
    }
    if args.kind == "badtwist":  # 8 bytes of CDR where a Twist has 52: published as raw bytes
        cls, msg = Twist, b"\x00\x01\x00\x00" + b"\x00" * 4
    else:
        cls, make = kinds[args.kind]
        msg = make(args.value)
    pub = node.create_publisher(cls, args.topic, 10)
    if args.kind == "string":  # DDS refuses the mismatched type: nobody ever subscribes
        time.sleep(args.linger)
        return {"published": args.topic, "subscribers": pub.get_subscription_count()}
    wait_until(lambda: pub.get_subscription_count() > 0, 10.0, f"nobody subscribed {args.topic}")
    pub.publish(msg)
    time.sleep(args.linger)
    return {"published": args.topic, "subscribers": pub.get_subscription_count()}


def twist(v, w):
    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    return msg


def cmd_drive(node, args):
    """Publish a twist on cmd_vel at 20 Hz for ``--seconds``; odometry then and ``--idle`` later."""
    odom = Counter(node, ns(args, "odom"), Odometry)
    pub = publisher(node, ns(args, "cmd_vel"), Twist, depth=10)
    return shared.drive(args, lambda v, w: pub.publish(twist(v, w)), odom, odom_dict)


def cmd_sync(node, args):
    """Trigger one step, then ``n`` more; report /clock before and after."""
    trigger = publisher(node, ns(args, "triggerNextStep"), Bool)
    done = Counter(node, ns(args, "simulationStepDone"), Bool)
    clock = Counter(node, "/clock", Clock)
    matched(node, done)
    matched(node, clock)
    return shared.sync(
        args, lambda: trigger.publish(Bool(data=True)), done, clock, lambda m: stamp_ns(m.clock)
    )


def cmd_states(node, args):
    """pause, start, stop, start: the simulationState after each, and /clock while paused."""
    state = Counter(node, ns(args, "simulationState"), Int32, keep=True, qos=LATCHED)
    clock = Counter(node, "/clock", Clock)
    pubs = {
        e: publisher(node, ns(args, f"{e}Simulation"), Bool) for e in ("start", "pause", "stop")
    }
    state.wait(1)
    matched(node, clock)
    return shared.states(args, state, clock, lambda event: pubs[event].publish(Bool(data=True)))


def cmd_topics(node, args):
    """The graph's topics, once every ``--expect``ed one is discovered (or ``--seconds`` passed)."""
    end = time.monotonic() + args.seconds
    while True:
        names = sorted(name for name, _ in node.get_topic_names_and_types())
        if (args.expect and set(args.expect) <= set(names)) or time.monotonic() > end:
            return names
        time.sleep(0.1)


def cmd_tutorialloop(node, args):
    """rosBubbleRob2 in sync mode: forward; after sensorTrigger back up turning for a while."""
    trig = Counter(node, ns(args, "sensorTrigger"), Bool)
    done = Counter(node, ns(args, "simulationStepDone"), Bool)
    term = Counter(node, ns(args, "terminated"), Bool, keep=True)
    odom = Counter(node, ns(args, "odom"), Odometry, keep=True)
    action = Counter(node, ns(args, "bubblerob/action"), Float64MultiArray, keep=True)
    left = publisher(node, ns(args, "leftMotorSpeed"), Float32)
    right = publisher(node, ns(args, "rightMotorSpeed"), Float32)
    trigger = publisher(node, ns(args, "triggerNextStep"), Bool)
    start = publisher(node, ns(args, "startSimulation"), Bool)
    raw = {}
    for topic, cls in RAW_TOPICS.items():
        if args.raw:
            raw[topic] = []
            node.create_subscription(cls, ns(args, topic[1:]), raw[topic].append, 1000, raw=True)
    for c in (trig, done, term, odom, action):
        matched(node, c)
    start.publish(Bool(data=True))

    def wheels(left_speed, right_speed):
        left.publish(Float32(data=left_speed))
        right.publish(Float32(data=right_speed))

    triggers = shared.tutorial_loop(
        args, trig, done, wheels, lambda: trigger.publish(Bool(data=True))
    )
    if args.raw:
        with open(args.raw, "w") as f:
            json.dump({t: [bytes(m).hex() for m in msgs] for t, msgs in raw.items()}, f)
    return {
        "steps": done.count,
        "collisions": sum(m.data for m in term.all),
        "triggers": triggers,
        "actions": [list(m.data) for m in action.all],
        "odom": [[m.pose.pose.position.x, m.pose.pose.position.y] for m in odom.all],
        "sim_time": stamp_ns(odom.all[-1].header.stamp) - stamp_ns(odom.all[0].header.stamp),
    }


def cmd_localize(node, args):
    """Drive a circle; /amcl_pose and the truth; malformed /initialpose, then a valid one."""
    amcl = Counter(node, ns(args, "amcl_pose"), PoseWithCovarianceStamped, keep=True)
    truth = Counter(node, ns(args, "base_pose_ground_truth"), Odometry, keep=True)
    odom = Counter(node, ns(args, "odom"), Odometry)
    cloud = Counter(node, ns(args, "particlecloud"), PoseArray)
    tf = Counter(node, "/tf", TFMessage, keep=True)
    static = Counter(node, "/tf_static", TFMessage, keep=True, qos=LATCHED)
    for c in (amcl, truth, cloud):
        matched(node, c)
    init = publisher(node, ns(args, "initialpose"), PoseWithCovarianceStamped)
    publisher(node, ns(args, "cmd_vel"), Twist).publish(twist(args.linear, args.angular))
    io = shared.LocalizeIO(
        stamp_ns=stamp_ns,
        send_raw=lambda: init.publish(b"\x00\x01\x00\x00\x01"),  # CDR too short for the type
        send_pose=lambda *pose: init.publish(
            shared.fill_initial_pose(PoseWithCovarianceStamped(), *pose)
        ),
        frame="map",
    )
    return shared.localize(args, io, amcl, truth, odom, cloud, tf, static)


def main():
    parser, sub = shared.parser(linger=0.5)
    sub.choices["tutorialloop"].add_argument(
        "--raw", default=None, help="write the raw CDR of RAW_TOPICS here (JSON)"
    )
    sub.add_parser("echo").add_argument("--camera", action="store_true")
    p = sub.add_parser("topics")
    p.add_argument("--seconds", type=float, default=15.0)
    p.add_argument("--expect", nargs="*", default=[])
    args = parser.parse_args()
    rclpy.init()
    node = Node(
        "live_test_client",
        parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)],
    )
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        if args.cmd == "serve":
            made = Made(node)
            shared.serve(parser, lambda a: globals()["cmd_" + a.cmd](node, a), made.drop)
        else:
            result = globals()["cmd_" + args.cmd](node, args)
    finally:
        executor.shutdown()
        spinner.join(5.0)
        node.destroy_node()
        rclpy.try_shutdown()
    if args.cmd != "serve":
        print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
