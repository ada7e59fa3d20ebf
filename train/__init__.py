"""SB3 training for BubbleRob: ``python -m train --algo ppo --env BubbleRob-v0``.

:func:`train` trains one run (:mod:`train.trainer`); the hyperparameter format is
:mod:`train.zoo`, the vec envs :mod:`train.envs`, the native batch for SB3 :mod:`train.sb3_vec`.
The command line is ``bubblerob_cli.train``.
"""

from __future__ import annotations

from train.trainer import train
from train.zoo import ALGOS, load_hyperparams

__all__ = ["ALGOS", "load_hyperparams", "train"]
