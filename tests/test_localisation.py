"""The particle filter (issue #27): its parts against independent oracles, then whole episodes.

The episode tests record 30 s of the laser policy with drifting odometry
(``odometry_noise=0.1``) and check issue #27's targets on two seeds the filter was not tuned on
(tuning used seeds 0-19): the raw odometry is off by >= 0.2 m at the end, tracking from the
start pose is within 0.05 m and 0.05 rad on average after convergence, and global localisation
converges within 10 s.
bench/localisation.py measures the same on 50 held-out seeds.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.localisation import LikelihoodField, ParticleFilter
from bubblerob_env.localisation.evaluation import (
    first_settled,
    localise,
    record_episode,
    scan_geometry,
)
from bubblerob_env.localisation.field import squared_distance_transform
from bubblerob_env.localisation.laser_model import LaserModel
from bubblerob_env.localisation.motion import MotionNoise, compose, relative_motion, sample_motion
from bubblerob_env.localisation.resampling import kld_particle_count, low_variance_indices
from bubblerob_env.mapping import episode_grid
from policies import load_policy


def test_distance_transform_equals_brute_force():
    rng = np.random.default_rng(0)
    occupied = rng.random((23, 31)) < 0.05
    occupied[0, 0] = True
    rows, cols = np.nonzero(occupied)
    grid_r, grid_c = np.mgrid[0:23, 0:31]
    brute = ((grid_r[..., None] - rows) ** 2 + (grid_c[..., None] - cols) ** 2).min(axis=-1)
    assert np.array_equal(squared_distance_transform(occupied), brute.astype(float))


def test_low_variance_resampling_copies_each_particle_n_times_its_weight():
    rng = np.random.default_rng(1)
    weights = rng.random(50) ** 3
    indices = low_variance_indices(weights, 1000, rng)
    counts = np.bincount(indices, minlength=50)
    expected = 1000 * weights / weights.sum()
    assert np.all(np.abs(counts - expected) < 1.0 + 1e-9)


def test_kld_count_grows_with_the_bins_occupied():
    one_bin = np.zeros((100, 3))
    spread = np.random.default_rng(2).uniform(-2, 2, (5000, 3))
    assert kld_particle_count(one_bin) == 1
    # Fox (2003), eq. 11 with k = 2 bins: (k-1)/(2 eps) * (1 - 2/9 + sqrt(2/9) z)^3.
    two_bins = np.array([[0.1, 0.1, 0.0], [0.7, 0.1, 0.0]])
    expected = 1 / 0.02 * (1 - 2 / 9 + math.sqrt(2 / 9) * 3.0) ** 3
    assert kld_particle_count(two_bins) == math.ceil(expected)
    assert kld_particle_count(spread) > 1000


def test_noise_free_motion_moves_every_particle_by_the_odometry_delta():
    rng = np.random.default_rng(3)
    particles = rng.uniform(-1, 1, (20, 3))
    for before, after in [
        (np.array([0.3, -0.2, 0.5]), np.array([0.5, 0.1, 1.4])),  # forwards and turning
        (np.array([0.0, 0.0, 0.0]), np.array([-0.2, 0.0, 0.1])),  # backwards
        (np.array([1.0, 1.0, 3.0]), np.array([1.0, 1.0, -3.0])),  # turning on the spot
    ]:
        moved = particles.copy()
        sample_motion(moved, before, after, MotionNoise(0.0, 0.0, 0.0, 0.0), rng)
        expected = compose(particles, relative_motion(before, after))
        np.testing.assert_allclose(moved[:, :2], expected[:, :2], atol=1e-12)
        yaw_gap = np.remainder(moved[:, 2] - expected[:, 2] + math.pi, 2 * math.pi) - math.pi
        np.testing.assert_allclose(yaw_gap, 0.0, atol=1e-12)


def test_the_true_pose_explains_a_simulated_scan_best():
    env = gym.make("BubbleRob-v0", laser_noise_std=0.01)
    obs, info = env.reset(seed=11)
    field = LikelihoodField(episode_grid(env, resolution=0.02))
    truth = np.array([info["x"], info["y"], info["yaw"]])
    offsets = np.array([[0, 0, 0], [0.05, 0, 0], [0, -0.05, 0], [0, 0, 0.05], [0.1, 0.1, -0.1]])
    scores = LaserModel().log_likelihood(
        truth + offsets, obs["laser"].astype(float), scan_geometry(env), field
    )
    assert np.argmax(scores) == 0 and np.all(scores[1:] < scores[0])


def test_update_before_start_is_a_clear_error():
    env = gym.make("BubbleRob-v0")
    obs, _ = env.reset(seed=0)
    pf = ParticleFilter(LikelihoodField(episode_grid(env)), scan_geometry(env))
    with pytest.raises(RuntimeError, match="start_at"):
        pf.update(np.zeros(3), obs["laser"])


@pytest.fixture(scope="module")
def episodes():
    env = gym.make("BubbleRob-v0", odometry_noise=0.1, laser_noise_std=0.01)
    policy = load_policy("laser", env)
    return [record_episode(env, policy, seed, max_steps=600) for seed in (7100, 7101)]


def test_tracking_beats_drifting_odometry(episodes):
    for episode in episodes:
        assert episode.odometry_error_final >= 0.2, episode.seed
        result = localise(episode, seed=1)
        assert result.converged_step is not None, episode.seed
        position, yaw = result.after_convergence()
        assert position <= 0.05 and yaw <= 0.05, (episode.seed, position, yaw)


def test_global_localisation_converges_within_10_s(episodes):
    for episode in episodes:
        result = localise(episode, global_start=True, seed=2)
        assert result.converged_step is not None, episode.seed
        assert result.converged_step * episode.dt <= 10.0, (episode.seed, result.converged_step)
        position, yaw = result.after_convergence()
        assert position <= 0.05 and yaw <= 0.05, (episode.seed, position, yaw)


def test_convergence_needs_a_settled_second_or_the_end():
    within = np.array([0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1], dtype=bool)
    assert first_settled(within, 3) == 4  # 4..6 hold; a lapse later does not undo it
    assert first_settled(within, 5) == 9  # no run of 5: the run that lasts to the end
    assert first_settled(np.zeros(4, dtype=bool), 2) is None


def test_readme_figure_command_writes_the_picture(tmp_path):
    out = tmp_path / "localisation.png"
    root = Path(__file__).resolve().parents[1]
    result = subprocess.run(
        [sys.executable, "docs/localisation_figure.py", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=root,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "python docs/localisation_figure.py" in (root / "README.md").read_text()
