"""SB3 training for BubbleRob: ``python -m train --algo ppo --env BubbleRob-v0``."""

from __future__ import annotations

from train.train import ALGOS, load_hyperparams, main, train

__all__ = ["ALGOS", "load_hyperparams", "main", "train"]
