"""Write ``cases.json``: the hostile campaign of issue #38, as data (``python make_cases.py``).

The cases are listed here by family, so that a reader sees why each is expected to be refused,
to print ``n/a`` or to run; ``cases.json`` is what ``run.py`` runs (commit both). Kinds follow
issue #38: 1 score over nothing, 2 option not honoured, 3 world not as asked, 4 outputs,
5 contexts that cannot work, 6 policies against the env, 7 exit codes and prefixes; 0 is every
other hostile input (bad values, bad files).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from action_type_cases import action_type_cases  # noqa: E402 - bench/hostile/action_type_cases.py
from output_cases import output_cases  # noqa: E402 - bench/hostile/output_cases.py
from teleop_cases import teleop_cases  # noqa: E402 - bench/hostile/teleop_cases.py

NAN, INF = "float('nan')", "float('inf')"

# Each env kwarg and values a hostile user passes that must be refused naming it.
BAD_KWARGS: dict[str, list[str]] = {
    "xml_file": ["'nope.xml'", "5", "'/etc/passwd'"],
    "action_type": ["'Wheels'", "''", "1"],
    "control_timestep": ["0", "-0.05", NAN, "'0.05'", "1e9"],
    "physics_substeps": ["0", "-1", "2.5", "10**6", "True"],
    "max_wheel_speed": ["0", "-1", NAN, "1e300", "False"],
    "max_linear_speed": ["0", "-1", INF, "'1'"],
    "max_angular_speed": ["0", "-3", NAN],
    "odometry_noise": ["-0.1", "2", NAN, "'0.1'"],
    "laser_num_rays": ["-1", "1.5", "10**7", "'360'"],
    "laser_fov": [NAN, INF, "'3'"],
    "laser_range_min": [NAN, "'0'", "10"],
    "laser_range_max": ["0", "-1", "1e300", NAN],
    "laser_noise_std": [NAN, INF, "-1"],
    "laser_backend": ["'fast'", "1"],
    "proximity_range_max": ["0", "-1", NAN],
    "proximity_trigger_distance": [NAN, "'x'"],
    "proximity_radiation_type": ["'laser'", "1"],
    "camera": ["'no'", "1", "'yes'"],
    "camera_width": ["0", "-32", "32.5", "'32'", "10**6"],
    "camera_height": ["0", "1e9"],
    "camera_shadows": ["'true'", "2"],
    "arena_size": ["0", "-3", NAN, "1e12", "'4'"],
    "num_obstacles": ["[5, 2]", "[-1, 3]", "[1.5, 3]", "3", "[0, 10**6]"],
    "obstacle_size": ["[5, 5]", "[0.3, 0.1]", "[-0.1, 0.2]", "[0, 0.1]", "'big'", "[0.1, 1.5]"],
    "obstacle_colours": ["'yes'", "1"],
    "start_clearance": ["-0.1", NAN, "100"],
    "start_pose": ["[100, 0, 0]", "[0, 0]", "'origin'", f"[{NAN}, 0, 0]"],
    "forward_reward_weight": [NAN, INF, "1e300", "'1'"],
    "spin_cost_weight": [NAN, "'x'"],
    "clearance_cost_weight": [INF],
    "clearance_distance": ["0", NAN, "0.01"],
    "collision_penalty": [NAN, "1e12"],
    "terminate_on_collision": ["'no'", "1"],
    "obs_mode": ["'Flat'", "3"],
    "render_mode": ["'window'", "1"],
    "render_width": ["0", "-1", "10**6"],
    "render_height": ["0"],
    "robot": ["'pioneer3'", "1"],
}

PIONEER_BAD = {
    "laser_num_rays": "-1",
    "arena_size": "0.5",
    "obstacle_size": "[4, 4]",
    "max_wheel_speed": "0",
    "camera": "'no'",
    "start_pose": "[100, 0, 0]",
    "odometry_noise": "2",
    "laser_range_max": "1e300",
    "camera_width": "0",
    "num_obstacles": "[4, 1]",
}

# Values that must be honoured: (kwargs, an assert on ``env`` and its first ``obs``).
HONOURED: list[tuple[str, str, str]] = [
    ("BubbleRob-v0", "laser_num_rays=90", "obs['laser'].shape == (90,)"),
    ("BubbleRob-v0", "camera_width=32", "obs['camera'].shape[:2] == (64, 32)"),
    ("BubbleRob-v0", "camera=True, camera_height=24", "obs['camera'].shape[0] == 24"),
    ("BubbleRob-v0", "camera=False", "'camera' not in obs"),
    ("BubbleRob-v0", "num_obstacles=[3, 3]", "len(env.unwrapped.layout.obstacles) == 3"),
    ("BubbleRob-v0", "num_obstacles=[0, 0]", "len(env.unwrapped.layout.obstacles) == 0"),
    (
        "BubbleRob-v0",
        "obstacle_size=[0.1, 0.1], num_obstacles=[2, 2]",
        "all(abs(s - 0.1) < 1e-9 for o in env.unwrapped.layout.obstacles for s in o.size)",
    ),
    (
        "BubbleRob-v0",
        "start_pose=[0.5, -0.5, 1.0]",
        "np.allclose(env.unwrapped.layout.start_pose, [0.5, -0.5, 1.0])",
    ),
    ("BubbleRob-v0", "obs_mode='flat'", "isinstance(obs, np.ndarray) and obs.ndim == 1"),
    ("BubbleRob-v0", "action_type='twist'", "env.unwrapped.action_type == 'twist'"),
    (
        "BubbleRob-v0",
        "obstacle_colours=True",
        "all(o.colour for o in env.unwrapped.layout.obstacles)",
    ),
    ("BubbleRob-v0", "arena_size=3.0", "env.unwrapped.arena_size == 3.0"),
    (
        "BubbleRob-v0",
        "arena_size=3.0, num_obstacles=[2, 2]",
        "all(abs(o.x) < 1.5 and abs(o.y) < 1.5 for o in env.unwrapped.layout.obstacles)",
    ),
    ("BubbleRob-v0", "laser_range_max=3.0", "float(obs['laser'].max()) <= 3.0"),
    ("BubbleRob-v0", "laser_num_rays=0", "'laser' not in obs"),
    ("BubbleRob-v0", "render_mode='rgb_array'", "env.render().ndim == 3"),
    ("PioneerP3DX-v0", "laser_num_rays=181", "obs['laser'].shape == (181,)"),
    ("PioneerP3DX-v0", "num_obstacles=[2, 2]", "len(env.unwrapped.layout.obstacles) == 2"),
    ("PioneerP3DX-v0", "camera_width=40", "obs['camera'].shape[1] == 40"),
    ("BubbleRob-v0", "odometry_noise=0.2", "env.unwrapped.config.odometry_noise == 0.2"),
    (
        "BubbleRob-v0",
        "obstacle_size=[1.0, 1.2], num_obstacles=[1, 1]",
        "len(env.unwrapped.layout.obstacles) == 1",
    ),
]


def env_cases() -> list[dict[str, Any]]:
    """Kinds 0, 2, 3: every kwarg's hostile values, contradictory pairs, honoured values."""
    cases: list[dict[str, Any]] = []
    for name, values in BAD_KWARGS.items():
        for k, value in enumerate(values):
            snippet = f"env = gym.make('BubbleRob-v0', {name}={value})\nenv.reset(seed=0)"
            if name == "render_mode":  # gym.make reads render_mode itself: the env's own check
                snippet = f"env = bubblerob_env.BubbleRobEnv({name}={value})"
            kind = 3 if name in ("obstacle_size", "num_obstacles") else 0
            says = name.replace("laser_", "")  # the laser's spec says "laser range_min"
            cases.append(
                {
                    "id": f"env-{name}-{k}",
                    "kind": kind,
                    "python": snippet,
                    "expect": "refuse",
                    "stderr_has": [says],
                }
            )
    for name, value in PIONEER_BAD.items():
        snippet = f"env = gym.make('PioneerP3DX-v0', {name}={value})\nenv.reset(seed=0)"
        cases.append(
            {
                "id": f"env-pioneer-{name}",
                "kind": 0,
                "python": snippet,
                "expect": "refuse",
                "stderr_has": [name],
            }
        )
    pairs = [
        ("camera-false-width", "camera=False, camera_width=32", "camera"),
        ("camera-false-height", "camera=False, camera_height=32", "camera"),
        ("range-min-over-max", "laser_range_min=4.0, laser_range_max=3.0", "range_min"),
        ("small-arena-big-clearance", "arena_size=1.0, start_clearance=0.5", "start_clearance"),
        (
            "pose-outside-small-arena",
            "arena_size=1.0, num_obstacles=[0, 0], start_pose=[0.9, 0, 0]",
            "start_pose",
        ),
        (
            "obstacles-too-big-small-arena",
            "arena_size=2.0, obstacle_size=[0.5, 0.6]",
            "obstacle_size",
        ),
        ("unknown-kwarg", "foo=1", "foo"),
        ("typo-kwarg", "laser_num_ray=10", "laser_num_ray"),
        ("flat-with-camera-is-refused", "obs_mode='flat', camera=True", "camera"),
        ("physics-step-too-long", "control_timestep=1.0, physics_substeps=1", "physics_substeps"),
    ]
    for name, kwargs, says in pairs:
        cases.append(
            {
                "id": f"env-pair-{name}",
                "kind": 2,
                "python": f"env = gym.make('BubbleRob-v0', {kwargs})\nenv.reset(seed=0)",
                "expect": "refuse",
                "stderr_has": [says],
            }
        )
    for k, (env_id, kwargs, check) in enumerate(HONOURED):
        snippet = (
            f"env = gym.make('{env_id}', {kwargs})\nobs, _ = env.reset(seed=3)\n"
            f"assert {check}, {kwargs!r}"
        )
        cases.append({"id": f"env-honoured-{k}", "kind": 2, "python": snippet, "expect": "ok"})
    for seed in range(6):  # every generated arena holds what was asked, or says it could not
        snippet = (
            "from bubblerob_env.arena import CrowdedArenaWarning\n"
            "with warnings.catch_warnings(record=True) as caught:\n"
            "    warnings.simplefilter('always')\n"
            f"    env = gym.make('BubbleRob-v0', num_obstacles=[12, 12], arena_size=3.0)\n"
            f"    env.reset(seed={seed})\n"
            "crowded = any(issubclass(w.category, CrowdedArenaWarning) for w in caught)\n"
            "assert crowded or len(env.unwrapped.layout.obstacles) == 12"
        )
        cases.append({"id": f"env-crowded-{seed}", "kind": 3, "python": snippet, "expect": "ok"})
    for k, resolution in enumerate((0.005, 0.3, 0.5, 0.77, 1.0)):
        snippet = (
            "from bubblerob_env.mapping import episode_grid, OCCUPIED\n"
            "env = gym.make('BubbleRob-v0', num_obstacles=[6, 6], obstacle_size=[0.05, 0.1])\n"
            "env.reset(seed=1)\n"
            f"grid = episode_grid(env, {resolution})\n"
            "for o in env.unwrapped.layout.obstacles:\n"
            "    j = int((o.x - grid.origin[0]) // grid.resolution)\n"
            "    i = int((o.y - grid.origin[1]) // grid.resolution)\n"
            "    near = grid.data[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2]\n"
            "    assert (near == OCCUPIED).any(), ('obstacle lost', o)\n"
            "assert (grid.data[0] == OCCUPIED).any() and (grid.data[-1] == OCCUPIED).any()"
        )
        cases.append({"id": f"env-truth-res-{k}", "kind": 3, "python": snippet, "expect": "ok"})
    return cases


def _refuse(
    case_id: str, kind: int, argv: list[str], says: str = "", **extra: Any
) -> dict[str, Any]:
    case = {"id": case_id, "kind": kind, "argv": argv, "expect": "refuse", "exit": 2}
    if says:
        case["stderr_has"] = [says]
    return {**case, **extra}


def record_cases() -> list[dict[str, Any]]:
    """``record``'s hostile options: refused before any bag folder exists."""
    rec = [
        "record",
        "--policy",
        "reactive",
        "--episodes",
        "1",
        "--max-steps",
        "3",
        "--no-progress",
        "--out",
        "out",
    ]
    c: list[dict[str, Any]] = []
    for k, (extra, says) in enumerate(
        [
            (["--episodes", "0"], "--episodes"),
            (["--episodes", "-1"], "--episodes"),
            (["--seed", "-1"], "--seed"),
            (["--format", "zip"], "--format"),
            (["--format", "mcap", "--compression", "bz2"], "compression"),
            (["--distro", "foxy"], "foxy"),
            (["--max-steps", "0"], "--max-steps"),
            (["--namespace", "bad name!"], "namespace"),
            (["--start-time", "yesterday"], "start"),
            (["--map-resolution", "0"], "resolution"),
            (["--map-resolution", "2"], "resolution"),
            (["--map-resolution", "nan"], "resolution"),
            (["--policy", "nosuch"], "nosuch"),
            (["--policy", "{junk_zip}"], "j.zip"),
            (["--policy", "{zip_pioneer}"], "policy"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--env-kwargs", '{"foo": 1}'], "foo"),
            (["--env-kwargs", "[1]"], "JSON object"),
            (["--env-kwargs", '{"obs_mode": "flat"}'], "obs_mode"),
            (["--env-kwargs", '{"render_mode": "human"}'], "display"),
            (["--env-kwargs", '{"camera": false, "camera_width": 32}'], "camera"),
            (["--env-kwargs", '{"obstacle_size": [5, 5]}'], "obstacle_size"),
            (["--env-kwargs", '{"arena_size": -3}'], "arena_size"),
            (
                ["--env", "PioneerP3DX-v0", "--env-kwargs", '{"laser_num_rays": -1}'],
                "laser_num_rays",
            ),
        ]
    ):
        c.append(_refuse(f"record-{k}", 0 if k < 16 else 5, rec + extra, says, absent=["out"]))
    c.append(_refuse("record-out-is-a-file", 4, [*rec[:-1], "{bag_mcap_file}"], "bag.mcap"))
    for k, extra in enumerate(
        (
            ["--camera", "--env-kwargs", '{"camera": false}'],
            ["--env-kwargs", '{"max_episode_steps": 9}'],
        )
    ):  # an option and --env-kwargs that say otherwise: neither silently dropped
        c.append(_refuse(f"record-pair-{k}", 2, rec + extra, "contradicts", absent=["out"]))
    return c


def bag_command_cases() -> list[dict[str, Any]]:
    """``replay``, ``info``, ``recover``, ``map``, ``localize``, ``detect``: hostile options."""
    c: list[dict[str, Any]] = []
    for k, (argv, says) in enumerate(
        [
            (["replay", "{bag}", "--episodes", "-1"], "episodes"),
            (["replay", "nosuch"], "nosuch"),
            (["replay", "{not_a_bag}"], "x.mcap"),
            (["replay", "{empty_dir}"], "empty_dir"),
            (["info", "nosuch"], "nosuch"),
            (["info", "{not_a_bag}"], "x.mcap"),
            (["info", "{empty_dir}"], "empty_dir"),
            (["recover", "nosuch"], "nosuch"),
            (["recover", "{not_a_bag}"], "x.mcap"),
        ]
    ):
        c.append(_refuse(f"bagcmd-{k}", 0, argv, says))
    m = ["map", "{bag}", "--out", "m.png"]
    for k, (extra, says) in enumerate(
        [
            (["--episode", "-1"], "--episode"),
            (["--episode", "5"], "--episode"),
            (["--resolution", "0"], "resolution"),
            (["--resolution", "2"], "resolution"),
            (["--resolution", "abc"], "resolution"),
            (["--out", "."], "directory"),
            (["--out", "m.jpg"], ".png"),
            (["--out", "{bag_mcap_file}"], ".png"),
            (["--out", "/proc/nope/m.png"], "cannot be written"),
            (["--out", "{bag}/m.png"], "inside a ROS 2 bag folder"),
            (["--env-kwargs", '{"render_mode": 1}'], "render_mode"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--env-kwargs", '{"arena_size": -3}'], "arena"),
            (["--env-kwargs", '{"foo": 1}'], "foo"),
            (["--env-kwargs", "[]"], "JSON object"),
        ]
    ):
        c.append(_refuse(f"map-{k}", 4 if "--out" in extra else 2, m + extra, says))
    for k, (bag, says) in enumerate(
        [
            ("{not_a_bag}", "x.mcap"),
            ("{empty_dir}", "empty_dir"),
            ("nosuch", "nosuch"),
        ]
    ):
        c.append(_refuse(f"map-bag-{k}", 0, ["map", bag, "--out", "m.png"], says))
    lo = ["localize", "{bag}"]
    for k, (extra, says) in enumerate(
        [
            (["--seed", "-1"], "--seed"),
            (["--out", "."], "directory"),
            (["--out", "x.jpg"], ".png"),
            (["--out", "{bag_mcap_file}"], ".png"),
            (["--out", "/proc/nope/l.png"], "cannot be written"),
            (["--out", "{bag}/l.png"], "inside a ROS 2 bag folder"),
        ]
    ):
        c.append(_refuse(f"localize-{k}", 4 if "--out" in extra else 0, lo + extra, says))
    for k, (bag, says) in enumerate(
        [
            ("{not_a_bag}", "x.mcap"),
            ("{empty_dir}", "empty_dir"),
            ("{bag_nomap}", "/map"),
            ("{bag_noscan}", "/scan"),
            ("{bag_noise_notruth}", "base_pose_ground_truth"),
        ]
    ):
        c.append(_refuse(f"localize-bag-{k}", 1, ["localize", bag, "--out", "l.png"], says))
    for k, (bag, says) in enumerate(
        [
            ("{bag}", "camera"),
            ("{not_a_bag}", "x.mcap"),
            ("{empty_dir}", "empty_dir"),
            ("{bag_pioneer}", "camera"),
        ]
    ):
        c.append(_refuse(f"detect-{k}", 0, ["detect", bag], says))
    return c


def run_command_cases() -> list[dict[str, Any]]:
    """``evaluate``, ``demo``, ``train``, ``node`` (before ROS starts): hostile options."""
    ev = ["evaluate", "--policy", "reactive", "--episodes", "1"]
    demo = ["demo", "--policy", "reactive", "--episodes", "1", "--no-video", "--out", "d"]
    tr = ["train", "--timesteps", "64", "--out", "run", "--no-progress"]
    node = ["node", "--max-steps", "5", "--master-timeout", "2"]
    c: list[dict[str, Any]] = []
    for k, (extra, says) in enumerate(
        [
            (["--episodes", "0"], "--episodes"),
            (["--seed", "-1"], "--seed"),
            (["--split", "test", "--seed", "5"], "--split"),
            (["--video", "x.avi"], ".mp4"),
            (["--video", "."], "directory"),
            (["--video-policy", "laser"], "--video-policy"),
            (["--per-episode", "{bag_mcap_file}"], ".json"),
            (["--per-episode", "{bag}/e.json"], "inside a ROS 2 bag folder"),
            (["--env-kwargs", '{"render_mode": 1}'], "render_mode"),
            (["--env-kwargs", '{"obs_mode": "pixels"}'], "obs_mode"),
            (["--per-episode", "."], "directory"),
            (["--per-episode", "/proc/nope/e.json"], "per-episode"),
            (["--per-episode", "e.txt"], ".json"),
            (["--per-episode", "e.json", "--video", "e.json"], "--video"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--env-kwargs", '{"foo": 1}'], "foo"),
            (["--env-kwargs", '{"render_mode": "human"}'], "display"),
            (["--env-kwargs", '{"obstacle_size": [5, 5]}'], "obstacle_size"),
            (["--env-kwargs", '{"camera": false, "camera_width": 32}'], "camera"),
            (["--policy", "nosuch"], "nosuch"),
            (["--policy", "{junk_zip}"], "j.zip"),
            (["--policy", "{junk_onnx}"], "j.onnx"),
            (["--policy", "{zip_pioneer}"], "policy"),
            (["--policy", "{zip_twist}"], "policy"),
            (["--env", "PioneerP3DX-v0", "--policy", "ppo"], "ppo"),
        ]
    ):
        kind = 4 if {"--video", "--per-episode"} & set(extra) else 7 if "--policy" in extra else 0
        c.append(_refuse(f"evaluate-{k}", kind, ev + extra, says, absent=["e.json"]))
    for k, (extra, says) in enumerate(
        [
            (["--episodes", "0"], "--episodes"),
            (["--policy", "nosuch"], "nosuch"),
            (["--env-kwargs", '{"foo": 1}'], "foo"),
            (["--seed", "-1"], "--seed"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--env-kwargs", '{"render_mode": "human"}'], "display"),
        ]
    ):
        c.append(_refuse(f"demo-{k}", 0, demo + extra, says, absent=["d"]))
    for k, (extra, says) in enumerate(
        [
            (["--timesteps", "0"], "--timesteps"),
            (["--n-envs", "0"], "--n-envs"),
            (["--set", "n_steps=-1"], "n_steps"),
            (["--set", "nope=1"], "nope"),
            (["--eval-freq", "0"], "--eval-freq"),
            (["--algo", "dqn"], "dqn"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--seed", "-1"], "--seed"),
            (["--torch-threads", "0"], "--torch-threads"),
        ]
    ):
        c.append(_refuse(f"train-{k}", 0, tr + extra, says, absent=["run"]))
    for k, (extra, says) in enumerate(
        [
            (["--namespace", "bad name!"], "namespace"),
            (["--seed", "-1"], "--seed"),
            (["--env-kwargs", '{"obs_mode": "flat"}'], "obs_mode"),
            (["--env-kwargs", '{"render_mode": "human"}'], "display"),
            (["--localize", "track", "--map-resolution", "1"], "map-resolution"),
            (["--localize", "global", "--map-resolution", "0.5"], "map-resolution"),
            (["--map-resolution", "0"], "resolution"),
            (["--rate-factor", "-1"], "rate"),
            (["--camera-size", "0"], "camera"),
            (["--env-kwargs", '{"action_type": "twist"}'], "wheels"),
            (["--start-time", "garbage"], "start"),
            (["--env", "Bogus-v9"], "Bogus-v9"),
            (["--env-kwargs", '{"laser_num_rays": 0}', "--localize", "track"], "laser"),
            (["--env-kwargs", '{"camera": false, "camera_width": 32}'], "camera"),
            (["--policy", "nosuch"], "nosuch"),
            (["--camera", "--env-kwargs", '{"camera": false}'], "contradicts"),
            (["--camera-size", "32x24", "--env-kwargs", '{"camera_width": 40}'], "contradicts"),
        ]
    ):
        c.append(_refuse(f"node-{k}", 5, node + extra, says, timeout=60))
    return c


def bag_cases() -> list[dict[str, Any]]:
    """Kinds 1 to 3: ``map`` over bags as users record them; IoUs over nothing; its options."""
    c: list[dict[str, Any]] = []
    for bag in (
        "bag",
        "bag_vrep",
        "bag_ns",
        "bag_res1",
        "bag_pioneer",
        "bag_ros1",
        "bag_noise",
        "bag_empty_arena",
        "bag_nomap",
    ):
        c.append(
            {
                "id": f"map-ok-{bag}",
                "kind": 1,
                "argv": ["map", "{" + bag + "}", "--out", "m.png"],
                "expect": "ok",
                "stdout_lacks": ["n/a", "scans: 0"],
            }
        )
    for bag in ("bag", "bag_vrep", "bag_ns"):
        for res in ("1", "0.3", "0.005"):
            c.append(
                {
                    "id": f"map-res-{bag}-{res}",
                    "kind": 3,
                    "argv": ["map", "{" + bag + "}", "--resolution", res, "--out", "m.png"],
                    "expect": "ok",
                    "stdout_lacks": ["n/a"],
                }
            )
    for bag in ("bag_norays", "bag_noscan"):
        c.append(
            {
                "id": f"map-na-{bag}",
                "kind": 1,
                "argv": ["map", "{" + bag + "}", "--out", "m.png"],
                "expect": "na",
            }
        )
    c.append(
        {
            "id": "map-env-kwargs-honoured",
            "kind": 2,
            "argv": [
                "map",
                "{bag}",
                "--out",
                "m.png",
                "--env-kwargs",
                '{"num_obstacles": [4, 10]}',
            ],
            "expect": "ok",
            "stdout_has": ["ground truth: the re-simulated episode"],
        }
    )
    c.append(
        {
            "id": "map-env-honoured",
            "kind": 2,
            "argv": ["map", "{bag}", "--out", "m.png", "--env", "BubbleRob-v0"],
            "expect": "ok",
            "stdout_has": ["ground truth: the re-simulated episode"],
        }
    )
    return c


def bag_reader_cases() -> list[dict[str, Any]]:
    """Kinds 1 and 4: ``localize``, ``detect``, ``info``, ``replay``; standard output."""
    c: list[dict[str, Any]] = []
    for bag in ("bag", "bag_vrep", "bag_ns", "bag_noise", "bag_ros1", "bag_pioneer"):
        c.append(
            {
                "id": f"localize-run-{bag}",
                "kind": 1,
                "argv": ["localize", "{" + bag + "}", "--out", "l.png"],
                "expect": "ok",
                "stdout_lacks": ["nan"],
            }
        )
    c.append({"id": "detect-na-cam1", "kind": 1, "argv": ["detect", "{bag_cam1}"], "expect": "na"})
    c.append(
        {
            "id": "detect-ok-cam",
            "kind": 1,
            "argv": ["detect", "{bag_cam}"],
            "expect": "ok",
            "stdout_lacks": ["n/a (no detection", "n/a (no object"],
        }
    )
    c.append(
        {
            "id": "detect-json-cam1",
            "kind": 1,
            "argv": ["detect", "{bag_cam1}", "--json"],
            "expect": "na",
        }
    )
    c.append(
        {
            "id": "replay-more-than-held",
            "kind": 2,
            "argv": ["replay", "{bag}", "--episodes", "7"],
            "expect": "ok",
            "stdout_has": ["1 episode(s)"],
        }
    )
    for bag in ("bag", "bag_vrep", "bag_ns", "bag_ros1", "bag_pioneer", "bag_cam"):
        c.append(
            {
                "id": f"info-{bag}",
                "kind": 0,
                "argv": ["info", "{" + bag + "}"],
                "expect": "ok",
                "stdout_has": ["episodes"],
            }
        )
        c.append(
            {"id": f"replay-{bag}", "kind": 0, "argv": ["replay", "{" + bag + "}"], "expect": "ok"}
        )
    for k, argv in enumerate(
        (["info", "{bag}"], ["map", "{bag}", "--out", "m.png"], ["detect", "{bag_cam}"])
    ):
        c.append(
            {
                "id": f"stdout-full-{k}",
                "kind": 4,
                "argv": argv,
                "stdout": "full",
                "expect": "refuse",
                "exit": 1,
                "stderr_has": ["standard output"],
            }
        )
        c.append(
            {
                "id": f"stdout-closed-{k}",
                "kind": 4,
                "argv": argv,
                "stdout": "closed",
                "expect": "refuse",
                "exit": 1,
                "stderr_has": ["standard output"],
            }
        )
    return c


def policy_cases() -> list[dict[str, Any]]:
    """Kind 6: policies loaded for envs they were not made for."""
    c: list[dict[str, Any]] = []
    for k, (path, env_id, kwargs, expect) in enumerate(
        [
            ("{zip_twist}", "BubbleRob-v0", "action_type='twist', laser_num_rays=36", "ok"),
            ("{zip_twist}", "PioneerP3DX-v0", "action_type='twist', laser_num_rays=36", "refuse"),
            (
                "{zip_twist}",
                "BubbleRob-v0",
                "action_type='twist', laser_num_rays=36, laser_range_max=3.0",
                "refuse",
            ),
            (
                "{zip_twist}",
                "BubbleRob-v0",
                "action_type='twist', laser_num_rays=36, max_linear_speed=0.1",
                "refuse",
            ),
            ("{zip_twist}", "BubbleRob-v0", "laser_num_rays=90", "refuse"),
            ("{zip_pioneer}", "BubbleRob-v0", "laser_num_rays=36", "refuse"),
            ("{zip_pioneer}", "PioneerP3DX-v0", "laser_num_rays=36", "ok"),
            ("ppo", "PioneerP3DX-v0", "", "refuse"),
            ("ppo", "BubbleRob-v0", "action_type='twist'", "refuse"),
            ("ppo", "BubbleRob-v0", "laser_num_rays=90", "refuse"),
            ("ppo", "BubbleRob-v0", "obs_mode='flat'", "ok"),
            ("laser", "BubbleRob-v0", "laser_num_rays=0", "refuse"),
            ("{junk_zip}", "BubbleRob-v0", "", "refuse"),
            ("nosuch", "BubbleRob-v0", "", "refuse"),
        ]
    ):
        snippet = (
            "from policies.loading import load_policy\n"
            "with warnings.catch_warnings():\n"
            "    warnings.simplefilter('ignore')\n"
            f"    env = gym.make('{env_id}', {kwargs})\n"
            f"    policy = load_policy('{path}', env)\n"
            "obs, _ = env.reset(seed=0)\n"
            "action = np.asarray(policy.predict(obs)[0])\n"
            "assert action.shape == env.action_space.shape and np.isfinite(action).all()"
        )
        case: dict[str, Any] = {"id": f"policy-{k}", "kind": 6, "python": snippet, "expect": expect}
        c.append(case)
    return c


def main() -> None:
    """Write cases.json and say how many of each kind."""
    cases = [
        *env_cases(),
        *record_cases(),
        *bag_command_cases(),
        *run_command_cases(),
        *bag_cases(),
        *bag_reader_cases(),
        *policy_cases(),
        *output_cases(),
        *teleop_cases(),
        *action_type_cases(),
    ]
    ids = [c["id"] for c in cases]
    assert len(ids) == len(set(ids)), "case ids must be unique"
    (HERE / "cases.json").write_text(json.dumps(cases, indent=1) + "\n")
    kinds: dict[Any, int] = {}
    for case in cases:
        kinds[case["kind"]] = kinds.get(case["kind"], 0) + 1
    print(f"{len(cases)} cases; by kind: {dict(sorted(kinds.items()))}")


if __name__ == "__main__":
    main()
