"""A warm start by imitation: behaviour cloning, then DAgger, of a hand-written teacher.

rl-zoo's ``callback`` key names it (``train/hyperparams/ppo.yml``, ``BubbleRobNav-v0``)::

    callback:
      - train.imitation.ImitationWarmStart: {teacher: navigator, rounds: 8, ...}

Before the algorithm's first rollout, on the run's own training envs (whatever ``--vec-env``
steps them, under VecNormalize, whose statistics these steps warm up), the callback:

1. drives ``steps_per_round`` env steps with the teacher (``load_policy(teacher)``, e.g. the
   ``navigator``), recording each raw observation and the teacher's action for it;
2. fits the policy's deterministic action (the Gaussian's mean) to the teacher's actions (mean
   squared error, or with ``loss: l1`` mean absolute error: see :data:`LOSSES`),
   ``gradient_steps`` Adam steps on minibatches drawn from every sample recorded so far
   (behaviour cloning, Pomerleau 1991);
3. for each further round, lets the policy drive (the teacher's action taken with probability
   ``teacher_fraction``) and records the teacher's action for every state the policy visits,
   then fits again on all of it (DAgger, Ross et al. 2011): the policy learns to recover from
   its own mistakes, which pure cloning never shows it.

Then training goes on as usual (PPO on the task's reward from the imitated weights), and only
the network drives at test time: the teacher is a training signal, not part of the policy. The
rounds' losses, agreement and the policy's own success rate on its driven episodes go to
TensorBoard (``imitation/*``), and a progress bar counts the env steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.callbacks import BaseCallback
from torch.nn import functional  # imported with SB3 already

from policies.builtin import builtin_policy

__all__ = ["LOSSES", "ImitationWarmStart", "Recording"]


@dataclass
class Recording:
    """Raw observations (one array per key) and the teacher's actions for them, appended."""

    observations: dict[str, list[NDArray[np.float32]]] = field(default_factory=dict)
    actions: list[NDArray[np.float32]] = field(default_factory=list)

    def add(self, obs: dict[str, NDArray[Any]], actions: NDArray[np.float32]) -> None:
        """Append a batch (one row per env)."""
        for key, value in obs.items():
            self.observations.setdefault(key, []).append(np.asarray(value, np.float32).copy())
        self.actions.append(np.asarray(actions, np.float32).copy())

    def arrays(self) -> tuple[dict[str, NDArray[np.float32]], NDArray[np.float32]]:
        """Everything recorded so far, stacked."""
        obs = {key: np.concatenate(parts) for key, parts in self.observations.items()}
        return obs, np.concatenate(self.actions)


def _positive_int(label: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"ImitationWarmStart {label} must be an int >= 1, got {value!r}")
    return value


class ImitationWarmStart(BaseCallback):
    """Behaviour cloning then DAgger of ``teacher`` on the training envs, before RL starts.

    ``env_id`` and ``env_kwargs`` make the env the teacher is built for (its robot and laser);
    ``rounds`` rounds of ``steps_per_round`` env steps each (the first driven by the teacher);
    after each, ``gradient_steps`` Adam steps on minibatches of ``batch_size`` drawn from every
    sample so far, the step size decaying linearly from ``learning_rate`` to a tenth of it over
    the rounds. In later rounds the teacher's action is taken with probability
    ``teacher_fraction`` per env and step, the policy's otherwise. ``loss``: ``mse`` or ``l1``.
    """

    warm_start = True
    """It makes a model before the algorithm's first update (the trainer evaluates that one too)."""

    def __init__(
        self,
        teacher: str = "navigator",
        env_id: str = "BubbleRobNav-v0",
        env_kwargs: dict[str, Any] | None = None,
        rounds: int = 8,
        steps_per_round: int = 40_000,
        gradient_steps: int = 2000,
        batch_size: int = 256,
        learning_rate: float = 1e-3,
        teacher_fraction: float = 0.0,
        loss: str = "mse",
    ) -> None:
        super().__init__()
        self.teacher_name, self.env_id = teacher, env_id
        self.env_kwargs = dict(env_kwargs or {})
        self.rounds = _positive_int("rounds", rounds)
        self.steps_per_round = _positive_int("steps_per_round", steps_per_round)
        self.gradient_steps = _positive_int("gradient_steps", gradient_steps)
        self.batch_size = _positive_int("batch_size", batch_size)
        if not (isinstance(learning_rate, (int, float)) and learning_rate > 0):
            raise ValueError(f"ImitationWarmStart learning_rate must be > 0, got {learning_rate!r}")
        self.learning_rate = float(learning_rate)
        if not (isinstance(teacher_fraction, (int, float)) and 0.0 <= teacher_fraction <= 1.0):
            raise ValueError(
                f"ImitationWarmStart teacher_fraction must be in [0, 1], got {teacher_fraction!r}"
            )
        self.teacher_fraction = float(teacher_fraction)
        if loss not in LOSSES:
            raise ValueError(
                f"ImitationWarmStart loss must be one of {', '.join(LOSSES)}, got {loss!r}"
            )
        self.loss = loss
        self.recording = Recording()
        self.env_steps = 0
        """Env steps driven by imitation (not counted in the algorithm's timesteps)."""

    def _on_step(self) -> bool:
        return True

    def _on_training_start(self) -> None:
        import gymnasium as gym
        from tqdm import tqdm

        probe = gym.make(self.env_id, **self.env_kwargs)
        try:
            teacher = builtin_policy(self.teacher_name, probe)
        finally:
            probe.close()
        rng = np.random.default_rng(int(self.model.seed or 0))
        optimizer = _actor_optimizer(self.model.policy, self.learning_rate)
        total = self.rounds * self.steps_per_round
        with tqdm(total=total, desc="imitation", unit="step") as bar:
            for index in range(self.rounds):
                fraction = 1.0 if index == 0 else self.teacher_fraction
                successes, agreement = self._drive(teacher, fraction, rng, bar)
                for group in optimizer.param_groups:
                    group["lr"] = self.learning_rate * (1.0 - 0.9 * index / max(1, self.rounds - 1))
                loss = self._fit(optimizer, rng)
                self._log(index, loss, successes, agreement)
        # The algorithm starts from fresh episodes, as if nothing had been stepped.
        model: Any = self.model
        model._last_obs = self.training_env.reset()  # SB3's rollout state
        model._last_episode_starts = np.ones(self.training_env.num_envs, dtype=bool)

    def _drive(
        self, teacher: Any, fraction: float, rng: np.random.Generator, bar: Any
    ) -> tuple[list[bool], float]:
        """One round of steps; the finished episodes' successes and the policy's agreement."""
        env: Any = self.training_env
        count = env.num_envs
        obs = env.reset()
        starts = np.ones(count, dtype=bool)
        successes: list[bool] = []
        gaps: list[float] = []
        for _ in range(max(1, self.steps_per_round // count)):
            raw = _original(self.model, obs)
            labels, _ = teacher.predict(raw, episode_start=starts)
            labels = np.asarray(labels, np.float32)
            self.recording.add(raw, labels)
            own, _ = self.model.policy.predict(obs, deterministic=True)
            gaps.append(float(np.mean(np.abs(own - labels))))
            if fraction >= 1.0:
                actions = labels
            else:
                take = rng.random(count) < fraction
                actions = np.where(take[:, None], labels, own).astype(np.float32)
            obs, _, dones, infos = env.step(actions)
            starts = np.asarray(dones, dtype=bool)
            successes += [bool(infos[i].get("is_success", False)) for i in np.flatnonzero(starts)]
            self.env_steps += count
            bar.update(count)
        return successes, float(np.mean(gaps))

    def _fit(self, optimizer: Any, rng: np.random.Generator) -> float:
        """``gradient_steps`` steps on random minibatches of every sample; their mean loss."""
        import torch

        policy: Any = self.model.policy
        raw, targets = self.recording.arrays()
        normalizer = self.model.get_vec_normalize_env()
        obs: Any = raw if normalizer is None else normalizer.normalize_obs(raw)
        tensors = {
            key: torch.as_tensor(np.asarray(value, np.float32)) for key, value in obs.items()
        }
        target = torch.as_tensor(targets)
        policy.set_training_mode(True)
        losses = []
        for _ in range(self.gradient_steps):
            batch = torch.as_tensor(rng.integers(0, len(target), self.batch_size))
            mean = _action_mean(policy, {key: value[batch] for key, value in tensors.items()})
            loss: Any = LOSSES[self.loss](mean, target[batch])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses.append(float(loss.detach()))
        policy.set_training_mode(False)
        return float(np.mean(losses[-max(1, len(losses) // 4) :]))

    def _log(self, index: int, loss: float, successes: list[bool], agreement: float) -> None:
        self.logger.record("imitation/round", index)
        self.logger.record("imitation/loss", loss)
        self.logger.record("imitation/mean_action_gap", agreement)
        self.logger.record(
            "imitation/samples", len(self.recording.actions) * self.training_env.num_envs
        )
        if successes:
            self.logger.record("imitation/driven_success_rate", float(np.mean(successes)))
            self.logger.record("imitation/driven_episodes", len(successes))
        self.logger.dump(step=self.env_steps)


LOSSES = {"mse": functional.mse_loss, "l1": functional.l1_loss}
"""The fit's loss: ``mse`` fits the labels' mean on a state, ``l1`` their median (where a teacher
says turn left on some visits of a state and right on others, the mean is standing still; the
median is the more frequent side)."""


def _original(model: Any, obs: Any) -> dict[str, NDArray[Any]]:
    """The raw observation batch behind ``obs`` (VecNormalize's input, when there is one)."""
    normalizer = model.get_vec_normalize_env()
    raw = obs if normalizer is None else normalizer.get_original_obs()
    return dict(raw)


def _actor_optimizer(policy: Any, learning_rate: float) -> Any:
    """Adam over the parameters the deterministic action depends on (not the value head)."""
    import torch

    modules = (policy.pi_features_extractor, policy.mlp_extractor.policy_net, policy.action_net)
    parameters = [p for module in modules for p in module.parameters()]
    return torch.optim.Adam(parameters, lr=learning_rate)


def _action_mean(policy: Any, obs: dict[str, Any]) -> Any:
    """The Gaussian's mean for a normalised batch: ``predict(deterministic=True)``, unclipped."""
    features = policy.extract_features(obs, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))
