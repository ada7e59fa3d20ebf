"""Evaluation during training, on validation seeds only (``policies/protocol.py``).

Every periodic evaluation runs the same ``--eval-episodes`` episodes: validation seeds
``VALIDATION.start``, ``+1``, ... one episode per env of an eval batch of that many envs, so that
two evaluations of a run, and of two runs, compare like with like. The model kept as
``best_model.zip`` is the one with the best success rate on them, then the best mean return.
Training never starts an episode from a validation or test seed (its envs start from ``--seed +
i`` < 1000, then reset unseeded), and test seeds are never looked at here.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from policies.protocol import TRAINING, VALIDATION
from policies.runs import BEST_MODEL, normalization_path

__all__ = [
    "check_training_seeds",
    "evaluation_score",
    "keep_best_model",
    "validation_evaluation",
]


def check_training_seeds(seed: int, n_envs: int) -> None:
    """``ValueError`` unless the training envs' first seeds are training seeds."""
    if seed + n_envs > TRAINING.stop:
        raise ValueError(
            f"--seed {seed} with {n_envs} envs starts episodes from seeds {seed}-"
            f"{seed + n_envs - 1}; training seeds are {TRAINING.start}-{TRAINING.stop - 1} "
            f"(policies/protocol.py): use --seed from 0 to {TRAINING.stop - n_envs}"
        )


def evaluation_score(successes: Sequence[Any], mean_return: float) -> tuple[float, float]:
    """How a run ranks its evaluations: success rate of the latest one first, then mean return.

    ``successes`` is SB3's ``EvalCallback.evaluations_successes`` (one list per evaluation).
    """
    return (float(np.mean(successes[-1])) if len(successes) else 0.0, float(mean_return))


def keep_best_model(out: Path) -> Any:
    """An SB3 callback for ``EvalCallback(callback_after_eval=...)`` that keeps the safest model.

    After each evaluation it saves ``out/best_model.zip`` (and its VecNormalize statistics) when
    :func:`evaluation_score` beats every earlier one. SB3's own ``best_model`` is the highest mean
    return, so a fast policy that crashes in one evaluation episode out of ten would beat a safe
    one; here success comes first.
    """
    from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

    class KeepBestModel(BaseCallback):
        best: tuple[float, float] = (-float("inf"), -float("inf"))

        def _on_step(self) -> bool:
            evaluation = self.parent
            assert isinstance(evaluation, EvalCallback)
            score = evaluation_score(evaluation.evaluations_successes, evaluation.last_mean_reward)
            if score > self.best:
                self.best = score
                self.model.save(out / BEST_MODEL)
                normalizer = self.model.get_vec_normalize_env()
                if normalizer is not None:
                    normalizer.save(str(normalization_path(out / BEST_MODEL)))
            return True

    return KeepBestModel()


def validation_evaluation(eval_env: Any, at_start: bool = False, **kwargs: Any) -> Any:
    """SB3's ``EvalCallback`` that resets ``eval_env`` to validation seeds before each evaluation.

    ``eval_env`` has one env per evaluation episode (``n_eval_episodes == eval_env.num_envs``):
    SB3 then runs exactly one episode per env, env ``i`` from seed ``VALIDATION.start + i``.
    ``at_start``: evaluate at the first step too, before the algorithm's first update, so that a
    warm-started model (:class:`train.imitation.ImitationWarmStart`, which runs before it) is
    one of those the best model is kept from.
    """
    from stable_baselines3.common.callbacks import EvalCallback

    class _ValidationEvaluation(EvalCallback):
        def _on_step(self) -> bool:
            if at_start and self.n_calls == 1 and self.eval_freq > 1:
                self.n_calls = self.eval_freq  # SB3 evaluates when n_calls is a multiple of it
                try:
                    return self._on_step()
                finally:
                    self.n_calls = 1
            if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
                self.eval_env.seed(VALIDATION.start)  # used by evaluate_policy's reset()
            return bool(super()._on_step())

    if kwargs.get("n_eval_episodes") != eval_env.num_envs:
        raise ValueError("one eval env per evaluation episode")
    return _ValidationEvaluation(eval_env, **kwargs)
