"""``bubblerob demo``: the shipped policy drives; a table, an MCAP bag and a video come out."""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from bubblerob_cli.action_type import add_action_type_option
from bubblerob_cli.args import add_env_arguments
from bubblerob_cli.foxglove_view import add_foxglove_option, serve
from bubblerob_cli.outputs import Output, add_overwrite_option, require_outputs
from bubblerob_cli.policy_checks import check_episode_arguments, check_policies
from bubblerob_env.wrappers import TopDownView
from policies.evaluation import (
    DEFAULT_EVAL_SEED,
    EvalResult,
    FfmpegNotFoundError,
    VideoWriter,
    format_table,
    run_episode,
    step_bar,
    summarize,
)
from policies.loading import load_policy

__all__ = ["DemoResult", "add_demo_subcommand", "demo_bag", "demo_video", "run_demo"]


def add_demo_subcommand(subparsers: Any) -> None:
    """Register ``demo``."""
    demo = subparsers.add_parser(
        "demo",
        help="drive with the shipped policy: table, MCAP bag and video",
        description="Run a policy (default: the shipped PPO) for a few episodes, print its "
        "evaluation table, record the episodes as an MCAP bag and write a video.",
    )
    demo.add_argument(
        "--policy", default="ppo", help="ppo, laser, reactive, random, an .onnx or an SB3 .zip"
    )
    demo.add_argument("--episodes", type=int, default=3, help="episodes to drive and record")
    demo.add_argument("--seed", type=int, default=DEFAULT_EVAL_SEED, help="first episode seed")
    demo.add_argument("--out", type=Path, default=Path("demo_output"), help="output folder")
    demo.add_argument("--no-video", action="store_true", help="skip the video")
    add_overwrite_option(demo)
    add_action_type_option(demo)
    add_env_arguments(demo)
    add_foxglove_option(demo)
    demo.set_defaults(handler=_run_demo)


@dataclass(frozen=True)
class DemoResult:
    """What the demo made."""

    result: EvalResult
    bag: Path
    video: Path | None


def demo_bag(out: Path, policy_name: str) -> Path:
    """The demo's bag in ``out``."""
    return out / f"bubblerob_demo_{Path(policy_name).stem}"


def demo_video(out: Path, policy_name: str) -> Path:
    """The demo's video in ``out``: its bag's name and ``.mp4``."""
    return out / f"{demo_bag(out, policy_name).name}.mp4"


def run_demo(
    policy_name: str = "ppo",
    episodes: int = 3,
    seed: int = DEFAULT_EVAL_SEED,
    out: Path = Path("demo_output"),
    video: bool = True,
    progress: bool = True,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    foxglove: tuple[str, int] | None = None,
) -> DemoResult:
    """Drive ``episodes`` episodes of the env (default ``BubbleRob-v0``) with the policy, recording.

    The bag (ROS 2 MCAP, Jazzy) and the video of the first episode replace those of an earlier
    demo in ``out`` (``bubblerob demo`` refuses them without ``--overwrite``). With ``foxglove``
    (host, port) the episodes are also served live to Foxglove.
    """
    from bubblerob_env.ros import RosBagRecorder  # the [ros] extra

    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    env: gym.Env[Any, Any] = gym.make(env_id, **(env_kwargs or {}))
    if video:  # frames drawn with NumPy (~1 ms), not MuJoCo's renderer (~50 ms on a CPU)
        env = TopDownView(env, 360, 360)
    backend = None
    if foxglove is not None:
        from bubblerob_env.ros import RosLivePublisher
        from bubblerob_env.ros.live.foxglove_robot import publish_robot_model

        backend = serve("demo", foxglove)
        env = RosLivePublisher(env, backend, metadata={"policy": str(policy_name)})
        publish_robot_model(backend, env, env.topics)
    policy = load_policy(policy_name, env)
    bag = demo_bag(out, policy_name)
    command = shlex.join(["bubblerob", *sys.argv[1:]])
    recorder = RosBagRecorder(
        env,
        bag,
        format="mcap",
        overwrite=True,
        metadata={"policy": str(policy_name), "command": command},
    )
    video_path = demo_video(out, policy_name) if video else None
    stats = []
    # A bar of steps, not episodes: it moves while the first episode is filmed, too.
    bar = step_bar(env, episodes, f"demo {policy_name}", progress)
    limit = bar.total // episodes if bar.total else 0
    with recorder, bar:
        for index in range(episodes):
            bar.set_postfix(episode=f"{index + 1}/{episodes}", video=index == 0 and video)
            if index == 0 and video_path is not None:  # frames go to the encoder as they come
                with VideoWriter(video_path, env.metadata["render_fps"]) as writer:
                    episode = run_episode(recorder, policy, seed, writer, on_step=bar.update)
            else:
                episode = run_episode(recorder, policy, seed + index, on_step=bar.update)
            bar.update(max(0, limit - episode.length))  # an episode that ended early
            stats.append(episode)
    env.close()
    if backend is not None:
        backend.shutdown("done")
    return DemoResult(summarize(str(policy_name), stats), recorder.bag_paths[0], video_path)


def _run_demo(args: argparse.Namespace) -> int:
    check_episode_arguments("demo", args)
    bag = demo_bag(args.out, args.policy)
    require_outputs(
        "demo",
        [
            Output("--out", args.out, kind="folder"),
            Output("--out", bag, kind="bag"),
            None if args.no_video else Output("--out", demo_video(args.out, args.policy)),
        ],
        args.overwrite,
    )
    check_policies("demo", [args.policy], args.env, args.env_kwargs, args.action_type)
    try:
        return _demo_and_report(args)
    except OSError as error:  # an unwritable --out: the recorder or the video says where
        raise SystemExit(f"bubblerob demo: {error}") from None
    except FfmpegNotFoundError as error:  # one line: what to install
        raise SystemExit(str(error)) from None


def _demo_and_report(args: argparse.Namespace) -> int:
    """Run the demo and say where its outputs are."""
    demo = run_demo(
        args.policy,
        args.episodes,
        args.seed,
        args.out,
        not args.no_video,
        env_id=args.env,
        env_kwargs=args.env_kwargs,
        foxglove=args.foxglove,
    )
    print(format_table([demo.result]))
    print(f"bag:   {demo.bag}  (bubblerob info {demo.bag}; open in Foxglove or rosbags)")
    if demo.video is not None:
        print(f"video: {demo.video}")
    return 0
