"""The online loop shared by expert training (true reward), imitation (a learned reward) and a method with its own learner.

``online_loop`` plays an ``OnlineAgent`` in the environment, stores every transition, evaluates, checkpoints and
reports; what acts and learns is the agent's. ``TD3OnReward`` is TD3, one update per environment step, on a reward
model that decides what the buffer's rewards are: the environment's own (experts) or an imitation method's
(``methods/``: LWAIL's σ(−f) relabelled as f changes, GAIfO's, PWIL's); it asks the model for rewards, lets it update and
checkpoints it without knowing which it is. A method with its own loop (BCO) brings its own agent. The loop
reports through callbacks and hands its whole state (``resumable.capture``) to a callback; it never prints or touches paths."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np
import torch

from . import learning_curve as curve
from .envs import make_env
from .errors import RunPaused
from .resumable import EnvironmentState, NumpyGenerator, Stopwatch, capture, checkpoint_due, restore
from .rollout import Policy, rollout
from .seeds import stream_seeds

if TYPE_CHECKING:
    import gymnasium as gym

    from .config import TD3Config, TrainConfig
    from .evaluation import Reference
    from .replay import ReplayBuffer
    from .resumable import Part
    from .rollout import Rollouts
    from .td3 import TD3


class RewardModel(Protocol):
    def prepare(self, step: int, buffer: ReplayBuffer) -> None:
        """Make the buffer's rewards current before the update of env step ``step``."""

    def end_episode(self) -> None:
        """The transition ``prepare`` last rewarded ended an episode (terminated or truncated)."""

    def metrics(self, evaluation: Rollouts) -> dict[str, float]:
        """Diagnostics logged beside each evaluation (a fixed set of keys per reward model)."""

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


class EnvironmentReward:
    """The true reward, stored as collected (an expert, or the paper's TD3 baseline)."""

    def prepare(self, step: int, buffer: ReplayBuffer) -> None:
        pass

    def end_episode(self) -> None:
        pass

    def metrics(self, evaluation: Rollouts) -> dict[str, float]:
        return {}

    def state_dict(self) -> dict:
        return {}

    def load_state_dict(self, state: dict) -> None:
        pass


@dataclass
class RunState:
    """Everything beyond the networks that a resumed run needs to continue exactly."""

    step: int = 0
    episode_return: float = 0.0
    episode_returns: list[float] = field(default_factory=list)
    history: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    best_actor: dict | None = None  # the weights of the policy network (train.policy) at the best evaluation so far
    best_step: int = 0
    best_return: float = float("-inf")
    best_complete: bool = False  # no episode of the best evaluation ended early (``is_better``)


def evaluate_policy(agent: TD3, train: TrainConfig, env_id: str, seed: int, reference: Reference | None, reward_model: RewardModel,
                    start_noise: float = 0.0) -> dict[str, float]:
    """True return (and score) of the deterministic ``train.policy`` network, the reward model's diagnostics on the
    same episodes and, with ``train.evaluate_other``, each other network's return (and score) on those episodes too."""
    row, evaluation = evaluate_actor(partial(agent.act, which=train.policy), train, env_id, seed, reference, start_noise)
    values = agent.policy_values(np.concatenate([episode.observations for episode in evaluation.episodes]), which=train.policy)
    row |= {curve.Q_POLICY_MEAN: float(values.mean()), curve.Q_POLICY_STD: float(values.std())}
    row |= reward_model.metrics(evaluation)
    if train.evaluate_other:
        seeds = stream_seeds(seed, "evaluation", train.eval_episodes)
        for other in (name for name in agent.networks() if name != train.policy):
            row |= _scores(rollout(env_id, partial(agent.act, which=other), seeds, start_noise=start_noise).returns, reference, f"{other}_")
    return row


def evaluate_actor(policy: Policy, train: TrainConfig, env_id: str, seed: int, reference: Reference | None,
                   start_noise: float = 0.0) -> tuple[dict[str, float], Rollouts]:
    """True return (and score) of a deterministic ``policy``, its early ends and successes, and the episodes played.
    The episodes are the run seed's evaluation stream: the same at every evaluation of a run, whatever the method."""
    seeds = stream_seeds(seed, "evaluation", train.eval_episodes)
    evaluation = rollout(env_id, policy, seeds, record=True, start_noise=start_noise)
    row = _scores(evaluation.returns, reference, "", std=True) | {"episodes_terminated": int(evaluation.terminated.sum())}
    if evaluation.success_rate is not None:
        row[curve.SUCCESS_RATE] = evaluation.success_rate
    return row, evaluation


def is_better(row: dict, run: RunState) -> bool:
    """Does this evaluation beat the best so far? An evaluation with every episode complete (none ended by the
    environment, e.g. by a fall) beats one with an early end whatever the returns; among equals the higher mean wins."""
    complete = row["episodes_terminated"] == 0
    return run.best_actor is None or (complete, row["return_mean"]) > (run.best_complete, run.best_return)


def _scores(returns: np.ndarray, reference: Reference | None, prefix: str, std: bool = False) -> dict[str, float]:
    """``<prefix>return_mean`` (and ``return_std``) and, given a reference, ``<prefix>normalized_score``."""
    mean = float(returns.mean())
    row = {f"{prefix}return_mean": mean} | ({f"{prefix}return_std": float(returns.std())} if std else {})
    return row | ({} if reference is None else {f"{prefix}normalized_score": reference.normalize(mean)})


class OnlineAgent(Protocol):
    """What the online loop runs: an agent that acts, learns from the transitions the loop stores, and is evaluated
    (TD3 on a reward model: ``TD3OnReward``; a method with its own loop, e.g. methods/bco.py)."""

    def begin(self) -> None:
        """Before the first env step of a fresh run (not of a resumed one)."""

    def act(self, obs: np.ndarray, step: int, env: gym.Env, noise: np.random.Generator) -> np.ndarray:
        """The action at env step ``step`` (exploration included; ``noise``: the run's exploration generator)."""

    def learn(self, step: int, buffer: ReplayBuffer, ended: bool) -> None:
        """After the transition of env step ``step`` is stored (``ended``: it ended an episode)."""

    def evaluate(self) -> dict[str, float]:
        """The evaluation row (``evaluate_actor``'s columns and the agent's own)."""

    def policy(self) -> torch.nn.Module:
        """The network an evaluation judges (kept at the best one)."""


class TD3OnReward:
    """TD3 on a reward model: uniformly random actions for ``td3.random_steps``, then the actor with Gaussian noise;
    one update per env step from ``td3.learning_starts`` on, after the reward model has labelled the buffer."""

    def __init__(self, agent: TD3, reward_model: RewardModel, td3: TD3Config, train: TrainConfig, env_id: str, seed: int,
                 reference: Reference | None, start_noise: float):
        self.agent, self.reward_model, self.td3, self.train = agent, reward_model, td3, train
        self._evaluation = (env_id, seed, reference, reward_model, start_noise)

    def begin(self) -> None:
        pass

    def act(self, obs: np.ndarray, step: int, env: gym.Env, noise: np.random.Generator) -> np.ndarray:
        if step < self.td3.random_steps:
            return env.action_space.sample()
        low, high = env.action_space.low, env.action_space.high
        return np.clip(self.agent.act(obs) + noise.normal(0.0, self.td3.exploration_noise * (high - low) / 2), low, high)

    def learn(self, step: int, buffer: ReplayBuffer, ended: bool) -> None:
        self.reward_model.prepare(step, buffer)
        if ended:
            self.reward_model.end_episode()
        if step >= self.td3.learning_starts:
            self.agent.update(buffer.sample(self.td3.batch_size))

    def evaluate(self) -> dict[str, float]:
        return evaluate_policy(self.agent, self.train, *self._evaluation)

    def policy(self) -> torch.nn.Module:
        return self.agent.network(self.train.policy)


def train_td3(
    env_id: str,
    agent: TD3,
    buffer: ReplayBuffer,
    td3: TD3Config,
    train: TrainConfig,
    seed: int,
    reward_model: RewardModel | None = None,
    reference: Reference | None = None,
    resume: dict | None = None,
    on_progress: Callable[[int, RunState], None] | None = None,
    on_checkpoint: Callable[[dict], None] | None = None,
    on_evaluation: Callable[[RunState], None] | None = None,
    progress_every: int = 500,
    start_noise: float = 0.0,
    stop_requested: Callable[[], bool] | None = None,
) -> RunState:
    """Run TD3 up to ``train.steps`` env steps (from ``resume`` when given); returns the run's state. ``start_noise``:
    the start-state noise of every episode, trained on and evaluated (``make_env``); ``stop_requested``: ``online_loop``'s.

    Seed torch before building ``agent`` (and anything else random) for a reproducible run."""
    reward_model = reward_model or EnvironmentReward()
    learner = TD3OnReward(agent, reward_model, td3, train, env_id, seed, reference, start_noise)
    return online_loop(env_id, learner, buffer, train, seed, {"agent": agent, "reward_model": reward_model}, resume=resume,
                       on_progress=on_progress, on_checkpoint=on_checkpoint, on_evaluation=on_evaluation,
                       progress_every=progress_every, start_noise=start_noise, stop_requested=stop_requested)


def online_loop(
    env_id: str, learner: OnlineAgent, buffer: ReplayBuffer, train: TrainConfig, seed: int, parts: dict[str, Part], *,
    resume: dict | None = None, on_progress: Callable[[int, RunState], None] | None = None,
    on_checkpoint: Callable[[dict], None] | None = None, on_evaluation: Callable[[RunState], None] | None = None,
    progress_every: int = 500, start_noise: float = 0.0, stop_requested: Callable[[], bool] | None = None,
) -> RunState:
    """Play ``learner`` in the environment up to ``train.steps`` env steps, storing each transition in ``buffer``,
    evaluating every ``train.eval_every`` and checkpointing ``parts`` (with the buffer, the exploration generator and
    the environment) every ``train.checkpoint_every``; from ``resume`` when given. Returns the run's state. Every
    ``progress_every`` steps ``stop_requested`` is asked: when it says so the run checkpoints there and raises
    ``RunPaused`` (a resume goes on from that step as from any checkpoint)."""
    env = make_env(env_id, start_noise=start_noise)
    online_seed = stream_seeds(seed, "online")[0]
    obs, _ = env.reset(seed=online_seed)
    env.action_space.seed(online_seed)
    noise_rng = np.random.default_rng(online_seed)
    parts = parts | {"buffer": buffer, "noise_rng": NumpyGenerator(noise_rng), "env": EnvironmentState(env)}
    run = RunState()
    if resume is not None:
        restore(resume, parts)
        run, obs = RunState(**resume["run"]), resume["obs"].numpy()
    clock = Stopwatch(run.wall_time)

    def evaluate_now() -> None:
        run.wall_time = clock.elapsed()
        row = {"step": run.step, "wall_time": run.wall_time}
        row.update(learner.evaluate())
        if is_better(row, run):
            run.best_actor = {k: v.detach().clone() for k, v in learner.policy().state_dict().items()}
            run.best_step, run.best_return, run.best_complete = run.step, row["return_mean"], row["episodes_terminated"] == 0
        run.history.append(row)
        if on_evaluation is not None:
            on_evaluation(run)
        if on_progress is not None:
            on_progress(run.step, run)

    # Flush denormal floats to zero for the run: Adam's moments of units whose gradients stay 0 decay through the
    # denormal range, where every multiply takes ~100x longer (the critic's Adam step was 3x slower in a real run)
    torch.set_flush_denormal(True)
    try:
        if resume is None:
            learner.begin()
        while run.step < train.steps:
            action = learner.act(obs, run.step, env, noise_rng)
            next_obs, reward, terminated, truncated, _ = env.step(action)
            buffer.add(obs, action, reward, next_obs, terminated)
            run.episode_return += float(reward)
            run.step += 1
            ended = terminated or truncated
            if ended:
                run.episode_returns.append(run.episode_return)
                run.episode_return = 0.0
                obs, _ = env.reset()
            else:
                obs = next_obs
            learner.learn(run.step, buffer, ended)
            if run.step % train.eval_every == 0 or run.step == train.steps:
                evaluate_now()
            elif on_progress is not None and run.step % progress_every == 0:
                on_progress(run.step, run)
            stop = stop_requested is not None and run.step % progress_every == 0 and run.step < train.steps and stop_requested()
            if on_checkpoint is not None and (stop or checkpoint_due(run.step, train.checkpoint_every, train.steps)):
                run.wall_time = clock.elapsed()
                on_checkpoint(capture(parts, run=run.__dict__.copy(), obs=torch.from_numpy(np.asarray(obs))))
            if stop:
                raise RunPaused(run.step)
        if not run.history or run.history[-1]["step"] != run.step:  # resumed with --steps at its checkpoint
            evaluate_now()
    finally:
        torch.set_flush_denormal(False)  # torch's default, for whatever the process runs next
        env.close()
    run.wall_time = clock.elapsed()
    return run
