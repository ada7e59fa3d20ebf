"""Render README's localisation picture: true path, drifting odometry and the filter's estimate.

Run ``python docs/localisation_figure.py [OUT.png] [--seed S]``; the default output is
``docs/images/localisation.png``. One 50 s episode of the ``laser`` policy with
``odometry_noise=0.1`` is recorded, the particle filter localises globally over it (particles
everywhere at first), and the paths are drawn on the episode's map, with the particles of the
first update and the point where the filter converged.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import bubblerob_env  # noqa: E402, F401  (registers BubbleRob-v0)
from bubblerob_env.localisation import LikelihoodField, ParticleFilter  # noqa: E402
from bubblerob_env.localisation.evaluation import localise, record_episode  # noqa: E402
from policies import load_policy  # noqa: E402

DEFAULT_OUT = Path(__file__).resolve().parent / "images" / "localisation.png"


def main(argv: list[str] | None = None) -> int:
    """Record, localise and draw; print where the picture went and the episode's numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--seed", type=int, default=7003)
    args = parser.parse_args(argv)
    env = gym.make("BubbleRob-v0", odometry_noise=0.1, laser_noise_std=0.01)
    episode = record_episode(env, load_policy("laser", env), args.seed)
    result = localise(episode, global_start=True, seed=args.seed)
    first = ParticleFilter(LikelihoodField(episode.grid), episode.geometry, seed=args.seed)
    first.start_global()

    grid = episode.grid
    rows, cols = grid.data.shape
    extent = (
        grid.origin[0],
        grid.origin[0] + cols * grid.resolution,
        grid.origin[1],
        grid.origin[1] + rows * grid.resolution,
    )
    fig, ax = plt.subplots(figsize=(6, 6), dpi=100)
    ax.imshow(grid.data > 50, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1.4)
    ax.scatter(*first.particles[::25, :2].T, s=0.3, c="tab:orange", alpha=0.4)
    ax.plot(*episode.truth[:, :2].T, color="tab:green", lw=2.5, label="truth")
    ax.plot(*episode.odometry[:, :2].T, color="tab:red", lw=1.2, label="odometry")
    ax.plot(*result.estimates[:, :2].T, color="tab:blue", lw=1.0, ls="--", label="estimate")
    if result.converged_step is not None:
        x, y = result.estimates[result.converged_step, :2]
        ax.plot(x, y, "o", color="tab:blue", ms=7, label="converged")
    ax.scatter([], [], s=6, c="tab:orange", label="particles at the start")
    position, yaw = result.after_convergence()
    converged_s = (result.converged_step or 0) * episode.dt
    ax.set_title(
        f"seed {args.seed}: odometry off by {episode.odometry_error_final:.2f} m at the end;\n"
        f"estimate converged after {converged_s:.2f} s, then {100 * position:.1f} cm, "
        f"{1000 * yaw:.0f} mrad mean error",
        fontsize=9,
    )
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(
        f"wrote {args.out}: {episode.odometry_error_final:.2f} m odometry drift, "
        f"converged after {converged_s:.2f} s, {position:.3f} m / {yaw:.3f} rad after"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
