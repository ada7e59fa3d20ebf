"""The training and evaluation vec envs: ``make_vec_env``'s, or the native batch (``batched``).

``vec_env`` says how the ``n_envs`` training envs are stepped: ``dummy`` (in this process, the
default: with small, fast envs on a 2-core machine the inter-process round trips of
``SubprocVecEnv`` cost more than stepping them here), ``subproc`` (one subprocess each) or
``batched`` (:class:`train.sb3_vec.BubbleRobSB3VecEnv`, the same episodes) or ``worlds``
(:class:`train.worlds_vec.WorldsSB3VecEnv`: ``n_envs`` worlds of ``robots`` robots, a slot per
robot, for one policy shared by all; evaluated on single-robot episodes) or ``crowd`` (the
same over the :data:`CROWD_WORLDS` mix, ``n_envs`` x each group's weight; a Nav env id) or ``warp``
(:class:`train.sb3_warp.WarpSB3VecEnv`: ``n_envs`` MuJoCo Warp worlds on Warp's default device,
a GPU where there is one; evaluated on the CPU env, where the policy will run). The evaluation env
has one env per validation episode (``train/validation.py``), seeded from the first validation
seed, and the same wrapper chain as training's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from policies.builtin import builtin_policy
from policies.protocol import VALIDATION
from policies.runs import residual_scale, without_residual
from train.zoo import wrapper_class

__all__ = [
    "DEFAULT_VEC_ENV",
    "VEC_ENVS",
    "CROWD_WORLDS",
    "WORLDS_TASKS",
    "batch_wrapped",
    "batched_envs",
    "native_batch",
    "non_image_keys",
    "single_robot_eval_envs",
    "training_envs",
    "warp_envs",
    "worlds_envs",
]

VEC_ENVS = ("dummy", "subproc", "batched", "worlds", "crowd", "warp")
DEFAULT_VEC_ENV = "dummy"
"""Step the envs in the training process: on 2 cores, faster than subprocesses for this env."""


def training_envs(
    env_id: str,
    config: dict[str, Any],
    seed: int,
    eval_episodes: int,
    vec_env: str,
    robots: int = 8,
    foxglove: tuple[str, int] | None = None,
) -> tuple[Any, Any]:
    """The training envs and the evaluation env of ``config`` (rl-zoo's hyperparameters).

    Both wrapped in ``env_wrapper``, then VecNormalize (``normalize: true``; the evaluation's not
    updated) and VecFrameStack (``frame_stack: N``), as rl_zoo3 stacks them. With ``foxglove``
    (host, port) the first training env is published to Foxglove (:class:`WatchFirst`).
    """
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    env_kwargs = config.get("env_kwargs") or {}
    spec = config.get("env_wrapper")
    wrap = wrapper_class(spec)
    count = int(config["n_envs"])
    if foxglove is not None and vec_env != "dummy":
        raise ValueError("--foxglove watches a training env stepped here: use --vec-env dummy")
    if vec_env == "batched":
        envs = batched_envs(env_id, count, seed, env_kwargs, spec)
        # The same wrapper chain as training's: VecNormalize's statistics are synced by walking
        # both chains in step.
        eval_env = batched_envs(env_id, eval_episodes, VALIDATION.start, env_kwargs, spec)
    elif vec_env in ("worlds", "crowd"):  # the shared policy is evaluated driving one robot
        robots_or_mix = robots if vec_env == "worlds" else CROWD_WORLDS
        envs = worlds_envs(env_id, count, robots_or_mix, seed, env_kwargs, spec)
        eval_env = single_robot_eval_envs(env_id, eval_episodes, env_kwargs, spec)
    elif vec_env == "warp":  # evaluated on the CPU env, where the policy will run
        envs = warp_envs(env_id, count, seed, env_kwargs, spec)
        eval_env = single_robot_eval_envs(env_id, eval_episodes, env_kwargs, spec)
    else:
        made = env_id if foxglove is None else WatchFirst(env_id, foxglove)
        vec_cls = SubprocVecEnv if count > 1 and vec_env == "subproc" else DummyVecEnv
        shared = {"env_kwargs": env_kwargs, "wrapper_class": wrap}
        envs = make_vec_env(made, n_envs=count, seed=seed, vec_env_cls=vec_cls, **shared)
        # One env per validation episode (train/validation.py), stepped in this process.
        eval_env = make_vec_env(env_id, n_envs=eval_episodes, seed=VALIDATION.start, **shared)
    return _normalized_and_stacked(config, envs, eval_env)


def _normalized_and_stacked(config: dict[str, Any], envs: Any, eval_env: Any) -> tuple[Any, Any]:
    """VecNormalize (``normalize: true``) and VecFrameStack (``frame_stack: N``) over both."""
    from stable_baselines3.common.vec_env import VecFrameStack, VecNormalize

    if config.get("normalize", False):
        # rl-zoo's "normalize: true": running mean/std of observations (and returns for training).
        keys = non_image_keys(envs.observation_space)
        envs = VecNormalize(envs, gamma=float(config.get("gamma", 0.99)), norm_obs_keys=keys)
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False, norm_obs_keys=keys)
    if config.get("frame_stack"):
        # rl-zoo's "frame_stack: N", on top of the normalisation as rl_zoo3 stacks.
        envs = VecFrameStack(envs, int(config["frame_stack"]))
        eval_env = VecFrameStack(eval_env, int(config["frame_stack"]))
    return envs, eval_env


def non_image_keys(space: Any) -> list[str] | None:
    """The observation keys VecNormalize should normalise: all but images (the camera).

    SB3 scales and transposes uint8 images itself; normalised, they would be a float box it
    takes for a vector. ``None`` (all) for a space that is not a dict.
    """
    from gymnasium import spaces
    from stable_baselines3.common.preprocessing import is_image_space

    if not isinstance(space, spaces.Dict):
        return None
    return [key for key, sub in space.spaces.items() if not is_image_space(sub)]


def batched_envs(
    env_id: str, count: int, seed: int, env_kwargs: dict[str, Any], env_wrapper: Any = None
) -> Any:
    """``--vec-env batched`` with rl-zoo's ``env_wrapper`` (see :func:`native_batch`)."""
    scale = residual_scale(env_wrapper)
    spec = env_wrapper if scale is None else without_residual(env_wrapper)
    return native_batch(env_id, count, seed, env_kwargs, wrapper_class(spec), scale)


def native_batch(
    env_id: str,
    count: int,
    seed: int,
    env_kwargs: dict[str, Any],
    wrap: Any = None,
    scale: float | None = None,
) -> Any:
    """``--vec-env batched``: the native batch (threads), as ``make_vec_env`` would seed it.

    An ``env_wrapper`` of observation wrappers is applied to the whole batch (``LaserPooling``);
    a residual on the gap follower (``scale``, its wrapper left out of ``wrap``) below them.
    """
    import gymnasium as gym

    from train.sb3_vec import BubbleRobSB3VecEnv, VecObservationWrapper
    from train.vec_residual import VecResidualOnLaser

    if env_id != "BubbleRob-v0":
        raise ValueError(f"--vec-env batched steps BubbleRob-v0 only, not {env_id!r}")
    envs: Any = BubbleRobSB3VecEnv(count, **env_kwargs)
    envs.seed(seed)
    if wrap is None:
        return envs
    probe = gym.make(env_id, **env_kwargs)
    try:
        if scale is not None:  # the residual acts on the raw batch, below the observation ones
            envs = VecResidualOnLaser(envs, builtin_policy("laser", probe), scale)
        return VecObservationWrapper.from_env_wrapper(envs, wrap, probe)
    except ValueError:
        envs.close()
        raise
    finally:
        probe.close()


WORLDS_TASKS = {
    "bubblerob_env.env:BubbleRobEnv": "wander",
    "bubblerob_env.tasks.nav:BubbleRobNavEnv": "nav",
}
"""``--vec-env worlds``: the ``parallel_env`` task of each single env's entry point."""


_CIRCLE = {"scenario": "circle", "circle_jitter": 0.1, "world_steps": 500, "num_obstacles": (0, 0)}
CROWD_WORLDS = (
    (1, 4, _CIRCLE),
    (1, 8, _CIRCLE),
    (2, 12, _CIRCLE),
    (3, 20, _CIRCLE),
    (4, 8, {"scenario": "random"}),
)
"""``--vec-env crowd``: (worlds per ``n_envs``, robots, kwargs) of each group of worlds. Circle
crossings of 4 to 20 robots, no obstacles (a seeded turn and 0.1 m jitter along the circle;
redrawn every 500 steps, 25 s, so that the crossing starts again, a robot that ends meanwhile
restarting alone with a random goal) and random arenas of 8 robots among the obstacles; weighted
to the crowds the policy found hard (12 and 20 robots, random arenas: docs/LEARNING.md, the
seventh round): 128 robots per ``n_envs``."""


def worlds_envs(
    env_id: str,
    num_worlds: int,
    robots: int | Sequence[tuple[int, int, dict[str, Any]]],
    seed: int,
    env_kwargs: dict[str, Any],
    env_wrapper: Any = None,
) -> Any:
    """``--vec-env worlds``: ``num_worlds`` worlds of ``robots`` robots, one slot per robot.

    A Nav env id (``BubbleRobNav-v0``) gives every slot a goal (``task="nav"``); with
    ``robots=1`` the worlds are that env's.

    World ``w`` is seeded ``seed + w``; ``env_wrapper`` is applied as ``--vec-env batched``
    applies it (observation wrappers on the whole batch, a residual on the gap follower below).
    """
    import gymnasium as gym

    from train.worlds_vec import WorldsSB3VecEnv

    spec = gym.spec(env_id)
    task = WORLDS_TASKS.get(str(spec.entry_point))
    if task is None:
        raise ValueError(
            "--vec-env worlds steps BubbleRob-v0, PioneerP3DX-v0 or their Nav-v0 tasks, "
            f"not {env_id!r}"
        )
    kwargs = {"task": task, **spec.kwargs, **env_kwargs}
    if isinstance(robots, int):
        envs: Any = WorldsSB3VecEnv(num_worlds, robots, **kwargs)
    else:  # a mix of groups (--vec-env crowd)
        if task != "nav":
            raise ValueError(f"--vec-env crowd steps a Nav env (BubbleRobNav-v0), not {env_id!r}")
        groups = [(num_worlds * weight, n, own) for weight, n, own in robots]
        envs = WorldsSB3VecEnv.mixed(groups, **kwargs)
    envs.seed(seed)
    return batch_wrapped(envs, env_id, env_kwargs, env_wrapper)


def warp_envs(
    env_id: str, count: int, seed: int, env_kwargs: dict[str, Any], env_wrapper: Any = None
) -> Any:
    """``--vec-env warp``: ``count`` MuJoCo Warp worlds on Warp's default device.

    World ``i`` is seeded ``seed + i`` (the CPU env's arena for that seed); ``env_wrapper`` is
    applied as ``--vec-env batched`` applies it.
    """
    import importlib.util

    import gymnasium as gym

    spec = gym.spec(env_id)
    if spec.entry_point != "bubblerob_env.env:BubbleRobEnv":
        raise ValueError(f"--vec-env warp steps BubbleRob-v0 or PioneerP3DX-v0, not {env_id!r}")
    if importlib.util.find_spec("mujoco_warp") is None:
        raise ValueError(
            "--vec-env warp needs MuJoCo Warp: pip install 'bubblerob[warp]' "
            "(mujoco-warp and warp-lang)"
        )
    from train.sb3_warp import WarpSB3VecEnv

    envs: Any = WarpSB3VecEnv(count, **{**spec.kwargs, **env_kwargs})
    envs.seed(seed)
    return batch_wrapped(envs, env_id, env_kwargs, env_wrapper)


def single_robot_eval_envs(
    env_id: str, episodes: int, env_kwargs: dict[str, Any], env_wrapper: Any = None
) -> Any:
    """``--vec-env worlds``' evaluation: single-robot validation episodes, wrapped as training.

    The same wrapper chain as the worlds' (VecNormalize syncs its statistics by walking both).
    """
    from stable_baselines3.common.env_util import make_vec_env

    envs = make_vec_env(env_id, n_envs=episodes, seed=VALIDATION.start, env_kwargs=env_kwargs)
    return batch_wrapped(envs, env_id, env_kwargs, env_wrapper)


def batch_wrapped(envs: Any, env_id: str, env_kwargs: dict[str, Any], env_wrapper: Any) -> Any:
    """``envs`` in rl-zoo's ``env_wrapper`` applied to the whole batch, as ``batched`` does."""
    import gymnasium as gym

    from train.sb3_vec import VecObservationWrapper
    from train.vec_residual import VecResidualOnLaser

    scale = residual_scale(env_wrapper)
    wrap = wrapper_class(env_wrapper if scale is None else without_residual(env_wrapper))
    if wrap is None and scale is None:
        return envs
    probe = gym.make(env_id, **env_kwargs)
    try:
        if scale is not None:  # the residual acts on the raw batch, below the observation ones
            envs = VecResidualOnLaser(envs, builtin_policy("laser", probe), scale)
        return envs if wrap is None else VecObservationWrapper.from_env_wrapper(envs, wrap, probe)
    except ValueError:
        envs.close()
        raise
    finally:
        probe.close()


WATCH_BUDGET = 0.015
"""The fraction of the wall time publishing may take (``FoxglovePublisher``'s ``budget``).

1.5%, not the 5% that issue #39 allows training to slow: the budget counts the publisher's own
time, while a connected client and the server's threads take about as much again from training
on a 2-core machine (bench/foxglove_train_speed.py --client; docs/BENCHMARKS.md)."""


class WatchFirst:
    """Makes the envs of ``make_vec_env`` (in this process), the first one published to Foxglove.

    Whole episodes of that env go out while a client subscribes and publishing has cost at most
    :data:`WATCH_BUDGET` of the wall time
    (:class:`~bubblerob_env.ros.live.foxglove_publisher.FoxglovePublisher`), under ``Monitor``
    and ``env_wrapper``, so that Foxglove sees the env's own observations.
    """

    def __init__(self, env_id: str, address: tuple[str, int]) -> None:
        self.env_id = env_id
        self.address = address
        self.made = 0

    def __call__(self, **kwargs: Any) -> Any:
        import gymnasium as gym

        env = gym.make(self.env_id, **kwargs)
        self.made += 1
        if self.made > 1:
            return env
        from bubblerob_env.ros.live.foxglove_publisher import FoxglovePublisher

        return FoxglovePublisher(env, *self.address, budget=WATCH_BUDGET, watched_only=True)
