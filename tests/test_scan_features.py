"""``ScanConvExtractor``: a circular convolution over the scan, in a recipe, exported to ONNX."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
import torch  # noqa: E402

import bubblerob_env  # noqa: E402, F401
from policies import load_policy  # noqa: E402
from policies.scan_features import ScanConvExtractor  # noqa: E402
from train.zoo import algo_kwargs  # noqa: E402

NAV = "BubbleRobNav-v0"


def _batch(space: gym.spaces.Dict, count: int, seed: int = 0) -> dict[str, np.ndarray]:
    space.seed(seed)
    samples = [space.sample() for _ in range(count)]
    return {key: np.stack([s[key] for s in samples]) for key in space.spaces}


def test_a_turned_scan_turns_the_scan_features_and_nothing_else() -> None:
    """The oracle: turning the robot's scan by one stride of both layers (4 x 2 rays) moves every
    filter's map by one place round the circle, whatever the weights."""
    space = gym.make(NAV).observation_space
    extractor = ScanConvExtractor(space)
    batch = {k: torch.as_tensor(v) for k, v in _batch(space, 4).items()}
    turned = {**batch, "laser": torch.roll(batch["laser"], 8, dims=1)}
    with torch.no_grad():
        plain, rolled = extractor(batch), extractor(turned)
    maps = 16 * 45  # 360 rays: 90 after the first stride, 45 after the second
    assert extractor.features_dim == maps + 5 and plain.shape == (4, maps + 5)
    expected = torch.roll(plain[:, :maps].reshape(4, 16, 45), 1, dims=2).reshape(4, maps)
    torch.testing.assert_close(rolled[:, :maps], expected)
    torch.testing.assert_close(rolled[:, maps:], plain[:, maps:])
    # The other keys, in CombinedExtractor's order (sorted), divided by their spaces' bounds.
    goal = batch["goal"] / torch.tensor([5.656854, np.pi])
    torch.testing.assert_close(plain[:, maps : maps + 2], goal.float())


@pytest.mark.parametrize("circular", [True, False])
def test_the_float64_path_is_the_same_convolution(circular: bool) -> None:
    """The oracle: torch's own Conv1d in float64. The extractor's float64 path (gathers and a
    matmul, which onnxruntime runs: it has no float64 Conv) gives the same features, and its
    float32 path the same to float32's precision."""
    space = gym.make(NAV).observation_space
    extractor = ScanConvExtractor(space, circular=circular)
    batch = {k: torch.as_tensor(v) for k, v in _batch(space, 4).items()}
    wide = extractor.double()
    with torch.no_grad():
        features = wide({k: v.double() for k, v in batch.items()})
        laser = batch["laser"].double()[:, None, :] * wide.scale_laser
        expected = wide.scan(laser).flatten(1)  # torch's Conv1d, in float64
        narrow = wide.float()(batch)
    maps = expected.shape[1]
    assert features.dtype == torch.float64
    torch.testing.assert_close(features[:, :maps], expected, rtol=0, atol=1e-12)
    torch.testing.assert_close(narrow, features.float(), rtol=1e-5, atol=1e-5)


def test_an_env_without_a_scan_is_named_in_the_error() -> None:
    space = gym.make(NAV, laser_num_rays=0).observation_space
    with pytest.raises(ValueError, match=r"convolves the 'laser' observation; this env gives \["):
        ScanConvExtractor(space)


def test_a_recipe_names_it_and_a_bad_name_is_one_line() -> None:
    kwargs = algo_kwargs(
        {"policy_kwargs": {"features_extractor_class": "policies.scan_features.ScanConvExtractor"}}
    )
    assert kwargs["policy_kwargs"]["features_extractor_class"] is ScanConvExtractor
    with pytest.raises(ValueError, match="'policies.nowhere.Conv': not an importable"):
        algo_kwargs({"policy_kwargs": {"features_extractor_class": "policies.nowhere.Conv"}})


@pytest.mark.parametrize(
    ("setting", "named"),
    [
        (
            "policy_kwargs={features_extractor_class: policies.nowhere.Conv}",
            "features_extractor_class",
        ),
        ('callback=[{"nowhere.Thing": {}}]', "callback"),
        ("env_wrapper=policies.residual.NoSuchWrapper", "env_wrapper"),
    ],
)
def test_python_m_train_says_a_class_that_is_not_there_in_one_line(
    tmp_path, capsys, setting: str, named: str
) -> None:
    from bubblerob_cli.train import main

    out = tmp_path / "run"
    assert main(["--env", NAV, "--set", setting, "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"python -m train: {named} '")
    assert "not an importable module.Class" in err[0]
    assert not out.exists()  # refused before anything was made


def test_its_onnx_export_acts_as_the_model(tmp_path) -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    from policies.export_onnx import export_onnx

    envs = make_vec_env(NAV, n_envs=1, seed=0)
    kwargs = {"features_extractor_class": ScanConvExtractor, "net_arch": [32, 32]}
    PPO("MultiInputPolicy", envs, seed=0, device="cpu", policy_kwargs=kwargs).save(
        tmp_path / "model.zip"
    )
    (tmp_path / "config.yml").write_text(f"{NAV}:\n  normalize: false\n")
    out = export_onnx(tmp_path / "model.zip")
    env = gym.make(NAV)
    reference, exported = load_policy(tmp_path / "model.zip", env), load_policy(out, env)
    batch = _batch(env.observation_space, 300, seed=1)
    difference = np.abs(exported.predict(batch)[0] - reference.predict(batch)[0]).max()
    assert difference <= 1e-5
