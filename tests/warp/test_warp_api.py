"""``backend="warp"`` as Gymnasium users make and drive it (issue #29, items 1, 2 and 5).

The CPU batch is the reference for spaces, kwargs, autoreset modes and ``info`` keys; a second
run with the same seed is the reference for determinism.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("mujoco_warp")
import warp as wp  # noqa: E402

from bubblerob_env.backends import make_vector_env  # noqa: E402
from bubblerob_env.batch.cpu import BubbleRobVectorEnv  # noqa: E402
from bubblerob_env.mjwarp import WarpVectorEnv  # noqa: E402

N = 4
ROOT = Path(__file__).resolve().parents[2]


def _make(backend: str, **kwargs: object) -> gym.vector.VectorEnv:
    extra = {"device": "cpu", "layout_bank": 8} if backend == "warp" else {}
    return gym.make_vec(
        "BubbleRob-v0",
        num_envs=N,
        vectorization_mode="vector_entry_point",
        backend=backend,
        **extra,
        **kwargs,
    )


def _keys(info: dict[str, object]) -> set[str]:
    return set(info) - {"physics_diverged", "_physics_diverged"}


@pytest.mark.parametrize("autoreset_mode", ["NextStep", "SameStep"])
def test_spaces_and_info_keys_are_the_cpu_batchs(autoreset_mode: str) -> None:
    kwargs = {"max_episode_steps": 3, "autoreset_mode": autoreset_mode}
    warp_env, cpu_env = _make("warp", **kwargs), _make("cpu", **kwargs)
    assert isinstance(warp_env, WarpVectorEnv) and isinstance(cpu_env, BubbleRobVectorEnv)
    assert warp_env.observation_space == cpu_env.observation_space
    assert warp_env.action_space == cpu_env.action_space
    assert warp_env.metadata["autoreset_mode"] == cpu_env.metadata["autoreset_mode"]
    (warp_obs, warp_info), (_, cpu_info) = warp_env.reset(seed=3), cpu_env.reset(seed=3)
    assert _keys(warp_info) == _keys(cpu_info)
    assert warp_env.observation_space.contains(warp_obs)
    actions = np.full((N, 2), 0.3, dtype=np.float32)
    for _ in range(4):  # through the time limit and its autoreset
        warp_step, cpu_step = warp_env.step(actions), cpu_env.step(actions)
        assert _keys(warp_step[4]) == _keys(cpu_step[4])
        for key in _keys(cpu_step[4]) - {"final_obs", "final_info"}:
            assert np.asarray(warp_step[4][key]).dtype == np.asarray(cpu_step[4][key]).dtype, key
        for warp_part, cpu_part in zip(warp_step[1:4], cpu_step[1:4], strict=True):
            assert warp_part.shape == cpu_part.shape and warp_part.dtype == cpu_part.dtype
        assert warp_step[2].tolist() == cpu_step[2].tolist()  # no collision in 3 slow steps
        assert warp_step[3].tolist() == cpu_step[3].tolist()


def test_next_step_and_same_step_autoresets() -> None:
    actions = np.ones((N, 2), dtype=np.float32)
    next_step = _make("warp", max_episode_steps=2)
    next_step.reset(seed=8)
    next_step.step(actions)
    _, _, _, truncated, _ = next_step.step(actions)
    assert truncated.all()
    obs, rewards, terminated, truncated, info = next_step.step(actions)
    assert rewards.tolist() == [0.0] * N and not (terminated | truncated).any()
    assert not info["_is_success"].any() and info["sim_time"].tolist() == [0.0] * N
    assert next_step.observation_space.contains(obs)
    same_step = _make("warp", max_episode_steps=2, autoreset_mode="SameStep")
    same_step.reset(seed=8)
    same_step.step(actions)
    obs, _, _, truncated, info = same_step.step(actions)
    assert truncated.all() and info["_final_obs"].all()
    assert info["sim_time"].tolist() == [0.0] * N  # already reset
    assert info["final_info"]["sim_time"][0] > 0.0
    assert info["final_obs"][0]["laser"].shape == obs["laser"][0].shape


def _run(seed: int, steps: int, **kwargs: object) -> list[np.ndarray]:
    env = _make("warp", max_episode_steps=15, **kwargs)
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    trace = [obs["laser"], info["x"]]
    for _ in range(steps):
        obs, rewards, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, (N, 2)).astype(np.float32)
        )
        trace += [obs["laser"], rewards, terminated, truncated, info["odom_x"], info["y"]]
    return trace


def test_same_seed_same_episodes_bit_for_bit_through_autoresets() -> None:
    kwargs = {"laser_noise_std": 0.01, "odometry_noise": 0.05}
    first, second = _run(21, 30, **kwargs), _run(21, 30, **kwargs)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    other = _run(22, 30, **kwargs)
    assert not all(np.array_equal(a, b) for a, b in zip(first, other, strict=True))


def test_bad_input_is_one_clear_error_and_nothing_moves() -> None:
    env = _make("warp")
    env.reset(seed=1)
    before = env.worlds.data.qpos.numpy().copy()
    bad = np.zeros((N, 2), dtype=np.float32)
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"robot\(s\) \[2\] contain NaN"):
        env.step(bad)
    with pytest.raises(ValueError, match=r"shape \(4, 2\)"):
        env.step(np.zeros((3, 2)))
    assert np.array_equal(env.worlds.data.qpos.numpy(), before)
    with pytest.raises(ValueError, match="backend must be one of \\['cpu', 'warp'\\], got 'gpu'"):
        make_vector_env(2, backend="gpu")
    with pytest.raises(ValueError, match="camera=True is not available with backend='warp'"):
        make_vector_env(2, backend="warp", device="cpu", camera=True)
    with pytest.raises(ValueError, match="outputs must be one of"):
        make_vector_env(2, backend="warp", device="cpu", outputs="torch")
    with pytest.raises(ValueError, match="device='cuda:0' needs backend='warp'"):
        make_vector_env(2, device="cuda:0")
    with pytest.raises(
        ValueError, match=r"device must be one of this machine's Warp devices \[.*'cpu'.*got 'gpu'"
    ):
        make_vector_env(2, backend="warp", device="gpu")
    with pytest.raises(TypeError, match="unexpected keyword argument 'lazer'"):
        make_vector_env(2, backend="warp", device="cpu", lazer=1)
    with pytest.raises(RuntimeError, match="before reset"):
        _make("warp").step(np.zeros((N, 2)))


def test_device_outputs_are_warp_arrays_torch_reads_without_a_copy() -> None:
    torch = pytest.importorskip("torch")
    numpy_env = _make("warp", obs_mode="flat")
    device_env = _make("warp", obs_mode="flat", outputs="warp")
    numpy_obs, _ = numpy_env.reset(seed=4)
    device_obs, _ = device_env.reset(seed=4)
    assert isinstance(device_obs, wp.array) and device_obs.shape == numpy_obs.shape
    tensor = torch.from_dlpack(device_obs)
    assert tensor.data_ptr() == device_obs.ptr  # a view, not a copy
    assert np.array_equal(tensor.numpy(), numpy_obs)
    actions = torch.full((N, 2), 0.5)  # a tensor on the same device goes in as it is
    obs, rewards, terminated, truncated, info = device_env.step(actions)
    expected = numpy_env.step(actions.numpy())
    assert isinstance(rewards, wp.array) and rewards.dtype == wp.float32
    assert np.array_equal(torch.from_dlpack(obs).numpy(), expected[0])
    assert np.array_equal(rewards.numpy(), expected[1].astype(np.float32))
    assert terminated.numpy().tolist() == expected[2].tolist()
    assert set(info) == set(expected[4])
    actions[1, 0] = float("inf")
    with pytest.raises(ValueError, match="actions of robot 1 contain NaN or infinity"):
        device_env.step(actions)


def test_twist_actions_and_time_limits_pass_through() -> None:
    env = _make("warp", action_type="twist", max_episode_steps=2, laser_num_rays=0)
    obs, _ = env.reset(seed=2)
    assert set(obs) == {"proximity", "velocity"}
    env.step(np.tile([[1.0, 0.0]], (N, 1)))
    _, _, _, truncated, info = env.step(np.tile([[1.0, 0.0]], (N, 1)))
    assert truncated.all() and (info["body_twist"][:, 0] > 0.1).all()


def _run_script(path: Path, argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run a script in this process (Warp's kernels are loaded already) and return its stdout."""
    import runpy
    import sys

    saved = sys.argv
    sys.argv = [str(path), *argv]
    try:
        runpy.run_path(str(path), run_name="__main__")
    finally:
        sys.argv = saved
    return capsys.readouterr().out


@pytest.mark.parametrize(
    ("command", "rows"),
    [
        (
            ["warp_speed.py", "--sizes", "4", "--steps", "2"],
            ["device: cpu", "anchor: CPU native batch, N=64", "| 4 |", "MuJoCo Warp floor"],
        ),
        (
            ["warp_equivalence.py", "--quick"],
            [
                "device: cpu",
                "| laser vs mj_multiRay",
                "wall 1/1, cylinder 1/1, box 1/1",
                "| laser vs the CPU env",
            ],
        ),
    ],
)
def test_benchmarks_print_their_tables_naming_the_device(
    command: list[str], rows: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    """Smoke only: the bench scripts measure; a test never times anything."""
    script, *options = command
    out = _run_script(ROOT / "bench" / script, ["--device", "cpu", *options], capsys)
    for row in rows:
        assert row in out


def test_readme_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    readme = (ROOT / "README.md").read_text()
    blocks = [part.split("```")[0] for part in readme.split("```python\n")[1:]]
    (code,) = [block for block in blocks if 'backend="warp"' in block]
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
    assert "warp laser batch (16, 360) on cpu" in capsys.readouterr().out


def test_readme_figure_command_draws_both_backends(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert "`python docs/make_warp_figure.py`" in (ROOT / "README.md").read_text()
    out = tmp_path / "warp.png"
    script = ROOT / "docs" / "make_warp_figure.py"
    assert f"wrote {out}" in _run_script(script, ["--out", str(out), "--steps", "15"], capsys)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_same_step_device_outputs_keep_the_last_steps_reward() -> None:
    """A SameStep reset zeroes the world's reward on the device; the step still returns it."""
    kwargs = {"max_episode_steps": 2, "autoreset_mode": "SameStep"}
    numpy_env, device_env = _make("warp", **kwargs), _make("warp", outputs="warp", **kwargs)
    numpy_env.reset(seed=30)
    device_env.reset(seed=30)
    actions = np.full((N, 2), 0.8, dtype=np.float32)
    for _ in range(2):
        expected = numpy_env.step(actions)
        obs, rewards, terminated, truncated, info = device_env.step(actions)
    assert truncated.numpy().all() and expected[3].all()
    assert (expected[1] > 0.1).all()  # driving forward pays
    assert np.array_equal(rewards.numpy(), expected[1].astype(np.float32))
    assert np.array_equal(obs["laser"].numpy(), expected[0]["laser"])  # the reset observations
    assert info["_final_obs"].all()


def test_reset_mask_resets_only_those_worlds_and_a_diverged_world_truncates() -> None:
    env = _make("warp", max_episode_steps=50)
    env.reset(seed=40)
    for _ in range(3):
        env.step(np.full((N, 2), 0.5, dtype=np.float32))
    _, info = env.reset(options={"reset_mask": np.array([False, True, False, False])})
    assert info["_sim_time"].tolist() == [False, True, False, False]
    _, _, _, _, info = env.step(np.zeros((N, 2), dtype=np.float32))
    assert np.allclose(info["sim_time"], [0.2, 0.05, 0.2, 0.2], atol=1e-6)
    qvel = env.worlds.data.qvel.numpy()
    qvel[2, 0] = np.nan  # as a blown-up simulation leaves it
    env.worlds.data.qvel.assign(qvel)
    _, _, terminated, truncated, info = env.step(np.zeros((N, 2), dtype=np.float32))
    assert truncated.tolist() == [False, False, True, False] and not terminated.any()
    assert info["_physics_diverged"].tolist() == [False, False, True, False]
    assert "not finite" in info["physics_diverged"][2] and not info["is_success"][2]
    obs, rewards, _, truncated, info = env.step(np.zeros((N, 2), dtype=np.float32))
    assert rewards[2] == 0.0 and info["sim_time"][2] == 0.0  # reset, as Gymnasium's NextStep
    assert np.isfinite(obs["laser"]).all() and np.isfinite(env.worlds.data.qvel.numpy()).all()


def test_dropped_contacts_are_an_error_not_a_silent_step(monkeypatch: pytest.MonkeyPatch) -> None:
    from bubblerob_env.mjwarp import device

    monkeypatch.setattr(device, "CONTACTS_PER_WORLD", 1)  # a robot at rest has 5 contacts
    env = _make("warp")
    with pytest.raises(RuntimeError, match="world 0: MuJoCo Warp's buffers overflowed"):
        env.reset(seed=0)
        env.step(np.zeros((N, 2), dtype=np.float32))
    with pytest.raises(ValueError, match="graphs must be True or False, got 'yes'"):
        make_vector_env(2, backend="warp", device="cpu", graphs="yes")


def test_graph_replays_step_the_worlds_as_plain_launches_do() -> None:
    """From the third step a step is a replayed Warp graph: the same episodes, bit for bit."""
    runs = []
    for graphs in (False, True):
        env = _make("warp", max_episode_steps=6, graphs=graphs, laser_noise_std=0.01)
        obs, _ = env.reset(seed=50)
        rng = np.random.default_rng(50)
        trace = [obs["laser"]]
        for _ in range(14):  # through two autoresets
            obs, rewards, terminated, truncated, info = env.step(
                rng.uniform(-1, 1, (N, 2)).astype(np.float32)
            )
            trace += [obs["laser"], rewards, terminated, truncated, info["x"]]
        assert sorted(env.worlds._graphs) == (["physics", "sense"] if graphs else [])
        runs.append(trace)
    assert all(np.array_equal(a, b) for a, b in zip(*runs, strict=True))
