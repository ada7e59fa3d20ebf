"""Plot the shipped PPO policy's learning curve from its run's evaluation log.

Run ``python docs/plot_training.py [RUN_DIR] [OUT.png]``: ``RUN_DIR`` holds an ``evaluations.npz``
written by ``python -m train`` (default ``policies/trained``), the default output is
``docs/images/ppo_learning_curve.png``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_RUN = ROOT / "policies" / "trained"
DEFAULT_OUT = ROOT / "docs" / "images" / "ppo_learning_curve.png"


def plot(run_dir: Path, out: Path) -> None:
    """Mean evaluation return and success rate against env steps, side by side."""
    log = np.load(run_dir / "evaluations.npz")
    steps = log["timesteps"] / 1000
    fig, (returns, successes) = plt.subplots(1, 2, figsize=(9, 3.2))
    mean, std = log["results"].mean(axis=1), log["results"].std(axis=1)
    returns.plot(steps, mean, marker="o")
    returns.fill_between(steps, mean - std, mean + std, alpha=0.2)
    returns.set_xlabel("env steps (thousands)")
    returns.set_ylabel("evaluation return")
    successes.plot(steps, 100 * log["successes"].mean(axis=1), marker="o", color="tab:green")
    successes.set_ylim(0, 105)
    successes.set_xlabel("env steps (thousands)")
    successes.set_ylabel("success rate (%)")
    episodes = log["results"].shape[1]
    fig.suptitle(f"PPO on BubbleRob-v0: {episodes} validation episodes per evaluation")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)


def main(argv: list[str]) -> int:
    """Plot ``argv[0]`` (a run directory) to ``argv[1]``, with the defaults above."""
    run_dir = Path(argv[0]) if argv else DEFAULT_RUN
    out = Path(argv[1]) if len(argv) > 1 else DEFAULT_OUT
    plot(run_dir, out)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
