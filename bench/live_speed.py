"""Steps/s of ``bubblerob node --rate-factor max`` and messages/s a separate subscriber receives.

Usage: ``python bench/live_speed.py [--steps N] [--quick]``

``--quick`` (the tests' smoke run): 100 steps, the camera off on ROS 1 and on on ROS 2 only.

Starts its own ``rosmaster`` on a free loopback port. For the camera off and at 64x64, a
subscriber process (Debian's ``/usr/bin/python3`` + ``rospy``, raw ``AnyMsg`` on every topic the
node publishes) connects first, then starts the node's simulation (``startSimulation``); the node
runs ``N`` steps flat out. Reported: the env alone (no ROS, same process), the node's steps/s and
messages published/s, and the messages/s received with the share of published ones that arrived.
Needs Debian's ROS 1 (``python3-rospy``, ``python3-rosmaster``, ``python3-std-msgs``). Where
README's ``.venv-ros2`` exists, the same again on ROS 2: the node and an rclpy subscriber (raw
subscriptions, sensor-data QoS for sensors, reliable for the rest) run with its python.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.ros.live.ros1 import check_master

SUBSCRIBER = textwrap.dedent(
    """
    import json, sys, threading, time
    import rospy
    from std_msgs.msg import Bool
    steps = int(sys.argv[1]); topics = sys.argv[2:]
    rospy.init_node("bench_subscriber", anonymous=True, disable_signals=True)
    lock = threading.Lock(); counts = dict.fromkeys(topics, 0); times = []
    def make(topic):
        def cb(_):
            with lock:
                counts[topic] += 1
                times.append(time.perf_counter())
        return cb
    subs = [rospy.Subscriber(t, rospy.AnyMsg, make(t), queue_size=None, tcp_nodelay=True)
            for t in topics]
    start = rospy.Publisher("/startSimulation", Bool, queue_size=1, latch=True)
    end = time.monotonic() + 60
    while (min(s.get_num_connections() for s in subs) < 1 or start.get_num_connections() < 1):
        if time.monotonic() > end:
            sys.exit("the node did not connect")
        time.sleep(0.01)
    start.publish(Bool(True))
    done_topic = [t for t in topics if t.endswith("simulationStepDone")][0]
    last = time.monotonic() + 120
    while counts[done_topic] < steps and time.monotonic() < last:
        time.sleep(0.05)
    time.sleep(1.0)  # stragglers on other connections
    with lock:
        print(json.dumps({"counts": counts, "first": times[0], "last": times[-1]}), flush=True)
    """
)
SUBSCRIBER2 = textwrap.dedent(
    """
    import json, sys, threading, time
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, qos_profile_sensor_data
    from std_msgs.msg import Bool
    steps = int(sys.argv[1]); topics = [t.split("=") for t in sys.argv[2:]]
    rclpy.init(); node = rclpy.create_node("bench_subscriber")
    lock = threading.Lock(); counts = {t: 0 for t, _ in topics}; times = []
    def make(topic):
        def cb(_):
            with lock:
                counts[topic] += 1
                times.append(time.perf_counter())
        return cb
    sensors = {"LaserScan", "Range", "Image", "CameraInfo"}
    for topic, msgtype in topics:
        pkg, _, name = msgtype.split("/")
        cls = getattr(__import__(pkg + ".msg", fromlist=[name]), name)
        qos = qos_profile_sensor_data if name in sensors else QoSProfile(depth=1000)
        node.create_subscription(cls, topic, make(topic), qos, raw=True)
    start = node.create_publisher(Bool, "/startSimulation", 10)
    executor = SingleThreadedExecutor(); executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True); spinner.start()
    end = time.monotonic() + 60
    while (min(node.count_publishers(t) for t, _ in topics) < 1
           or start.get_subscription_count() < 1):
        if time.monotonic() > end:
            sys.exit("the node did not connect")
        time.sleep(0.01)
    time.sleep(0.5)  # discovery settles both ways
    start.publish(Bool(data=True))
    done_topic = [t for t, _ in topics if t.endswith("simulationStepDone")][0]
    last = time.monotonic() + 120
    while counts[done_topic] < steps and time.monotonic() < last:
        time.sleep(0.05)
    time.sleep(1.0)  # stragglers on other writers
    with lock:
        print(json.dumps({"counts": counts, "first": times[0], "last": times[-1]}), flush=True)
    executor.shutdown(); spinner.join(5); node.destroy_node(); rclpy.try_shutdown()
    """
)
ROS2_PYTHON = Path(__file__).resolve().parents[1] / ".venv-ros2" / "bin" / "python"
"""README's ROS 2 virtualenv (rclpy from the ros-jazzy wheels): the ROS 2 rows run there."""
TOPICS = [
    "/scan", "/proximity", "/sensorTrigger", "/odom", "/tf", "/clock", "/simulationTime",
    "/reward", "/terminated", "/truncated", "/bubblerob/action", "/simulationStepDone",
]  # fmt: skip
CAMERA_TOPICS = ["/camera/image_raw", "/camera/camera_info"]


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def env_alone(camera: bool, steps: int) -> float:
    """Steps/s of the env without ROS, with the node's sort of actions."""
    env = gym.make("BubbleRob-v0", camera=camera)
    env.reset(seed=0)
    action = np.array([0.8, 0.8], dtype=np.float32)
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def run_node(
    camera: bool, steps: int, ros_env: dict[str, str], home: Path, ros: int = 1
) -> dict[str, float]:
    """One node run with a subscriber; its rates."""
    topics = TOPICS + (CAMERA_TOPICS if camera else [])
    args = ["--rate-factor", "max", "--start", "stopped", "--steps", str(steps), "--watchdog", "0"]
    args += ["--camera"] if camera else []
    if ros == 1:
        python = sys.executable
        subscriber = subprocess.Popen(
            ["/usr/bin/python3", "-c", SUBSCRIBER, str(steps), *topics],
            env={"PATH": "/usr/bin:/bin", "HOME": str(home), **ros_env},
            stdout=subprocess.PIPE,
            text=True,
        )
    else:
        from bubblerob_env.ros.messages.topics import MSGTYPES, Topics

        keys = {name: key for key, name in Topics().resolved().items()}
        typed = [f"{t}={MSGTYPES[keys[t]] if t in keys else 'std_msgs/msg/Bool'}" for t in topics]
        python, args = str(ROS2_PYTHON), ["--ros", "2", *args]
        subscriber = subprocess.Popen(
            [python, "-c", SUBSCRIBER2, str(steps), *typed],
            env={**os.environ, **ros_env},
            stdout=subprocess.PIPE,
            text=True,
        )
    node = subprocess.run(
        [python, "-m", "bubblerob_cli", "node", *args],
        env={**os.environ, **ros_env},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if node.returncode != 0:
        subscriber.kill()
        raise RuntimeError(f"the node failed ({node.returncode}):\n{node.stdout}{node.stderr}")
    out, _ = subscriber.communicate(timeout=150)
    report = json.loads(out.strip().splitlines()[-1])
    match = re.search(r"(\d+) steps in ([\d.]+) s .* (\d+) messages published", node.stdout)
    assert match, node.stdout + node.stderr
    node_steps, node_wall, published = int(match[1]), float(match[2]), int(match[3])
    received = sum(report["counts"].values())
    span = report["last"] - report["first"]
    return {
        "steps_s": node_steps / node_wall,
        "published_s": published / node_wall,
        "received_s": received / span,
        "received_pct": 100.0 * received / (published + node_steps),  # + stepDone (not in sink)
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="steps per node run")
    parser.add_argument(
        "--quick", action="store_true", help="a smoke test: 100 steps, one run per ROS version"
    )
    args = parser.parse_args()
    steps = 100 if args.quick else args.steps
    # Each run starts a node and a subscriber (~5 s); the camera is one flag of the same code.
    cameras = {1: (False,), 2: (True,)} if args.quick else {1: (False, True), 2: (False, True)}
    port = free_port()
    ros_env = {"ROS_MASTER_URI": f"http://127.0.0.1:{port}/", "ROS_HOSTNAME": "127.0.0.1"}
    home = Path(os.environ.get("TMPDIR", "/tmp")) / f"bubblerob_live_bench_{port}"
    ros_env["ROS_HOME"] = str(home)
    master = subprocess.Popen(
        ["/usr/bin/rosmaster", "--core", "-p", str(port)],
        env={"PATH": "/usr/bin:/bin", "HOME": str(home), **ros_env},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    rows = []
    try:
        check_master(ros_env["ROS_MASTER_URI"], timeout=15)
        for camera in cameras[1]:
            alone = env_alone(camera, steps)
            rows.append((camera, alone, run_node(camera, steps, ros_env, home)))
    finally:
        master.terminate()
        master.wait(10)
    print(f"bubblerob node --rate-factor max, {steps} steps per run, ROS 1 (Debian rospy)")
    print_table(rows)
    if not ROS2_PYTHON.exists():
        print(f"\nROS 2: skipped, no {ROS2_PYTHON} (README: Live on a ROS 2 graph)")
        return
    # ROS 2: DDS on the loopback only, in a domain of its own
    ros2_env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": str(port % 100 + 1)}
    rows = []
    for camera in cameras[2]:
        alone = env_alone(camera, steps)
        rows.append((camera, alone, run_node(camera, steps, ros2_env, home, ros=2)))
    print(f"\n{steps} steps per run, ROS 2 Jazzy (rclpy 7.1.6, Fast DDS; sensor-data QoS for")
    print("sensors: best effort, so a subscriber that falls behind loses some)")
    print_table(rows)


def print_table(rows: list[tuple[bool, float, dict[str, float]]]) -> None:
    """The Markdown table of node runs."""
    header = ("camera", "env alone steps/s", "node steps/s", "published msg/s", "received msg/s",
              "received")  # fmt: skip
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for camera, alone, r in rows:
        print(
            f"| {'64x64' if camera else 'off'} | {alone:.0f} | {r['steps_s']:.0f} | "
            f"{r['published_s']:.0f} | {r['received_s']:.0f} | {r['received_pct']:.1f}% |"
        )


if __name__ == "__main__":
    main()
