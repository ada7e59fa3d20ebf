"""``bubblerob demo``: the shipped policy drives; a table, an MCAP bag and a video come out."""

from __future__ import annotations

import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym

from policies.evaluation import (
    DEFAULT_EVAL_SEED,
    EvalResult,
    VideoWriter,
    format_table,
    run_episode,
    summarize,
)
from policies.loading import load_policy

__all__ = ["DemoResult", "run_demo"]


@dataclass(frozen=True)
class DemoResult:
    """What the demo made."""

    result: EvalResult
    bag: Path
    video: Path | None


def run_demo(
    policy_name: str = "ppo",
    episodes: int = 3,
    seed: int = DEFAULT_EVAL_SEED,
    out: Path = Path("demo_output"),
    video: bool = True,
    progress: bool = True,
) -> DemoResult:
    """Drive ``episodes`` episodes of ``BubbleRob-v0`` with the policy, recording a bag.

    The bag (ROS 2 MCAP, Jazzy) and the video of the first episode replace those of an earlier
    demo in ``out``.
    """
    from bubblerob_env.ros import RosBagRecorder  # the [ros] extra

    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    env = gym.make("BubbleRob-v0", render_mode="rgb_array", render_width=360, render_height=360)
    policy = load_policy(policy_name, env)
    bag = out / f"bubblerob_demo_{Path(policy_name).stem}"
    command = shlex.join(["bubblerob", *sys.argv[1:]])
    recorder = RosBagRecorder(
        env,
        bag,
        format="mcap",
        overwrite=True,
        metadata={"policy": str(policy_name), "command": command},
    )
    video_path = out / f"bubblerob_demo_{Path(policy_name).stem}.mp4" if video else None
    stats = []
    from tqdm import tqdm

    bar = tqdm(total=episodes, desc=f"demo {policy_name}", unit="episode", disable=not progress)
    with recorder, bar:
        for index in range(episodes):
            if index == 0 and video_path is not None:  # frames go to the encoder as they come
                with VideoWriter(video_path, env.metadata["render_fps"]) as writer:
                    episode = run_episode(recorder, policy, seed, writer)
            else:
                episode = run_episode(recorder, policy, seed + index)
            stats.append(episode)
            bar.set_postfix(steps=episode.length, collided=episode.collided)
            bar.update()
    env.close()
    return DemoResult(summarize(str(policy_name), stats), recorder.bag_paths[0], video_path)


def main_demo(policy: str, episodes: int, seed: int, out: Path, video: bool) -> int:
    """Run the demo and say where its outputs are."""
    demo = run_demo(policy, episodes, seed, out, video)
    print(format_table([demo.result]))
    print(f"bag:   {demo.bag}  (bubblerob info {demo.bag}; open in Foxglove or rosbags)")
    if demo.video is not None:
        print(f"video: {demo.video}")
    return 0
