"""An online run from its opened run folder to its results: what `expert train` and `imitate` share.

A stage opens the run (``runs.open_run``), calls ``start_online_run`` (which seeds torch), builds what it adds
(LWAIL's reward model), and trains through ``session``'s hooks: TD3 with ``train_policy``, or the loop of a method
that has its own (BCO); it writes its own artifact from what it gets back."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import pandas as pd
import torch

from .. import learning_curve
from ..errors import LwailError
from ..methods import METHODS, Session
from ..replay import ReplayBuffer
from ..td3 import TD3
from ..training import RunState, train_td3
from .shared import Progress, require_memory

if TYPE_CHECKING:
    from pathlib import Path

    from .. import config as cfg
    from ..envs import EnvInfo
    from ..evaluation import Reference
    from ..runs import Run
    from ..training import RewardModel


PROGRESS_EVERY = 100  # env steps between progress reports: a bar that moves smoothly, at a few updates a second


@dataclass(frozen=True)
class TrainedPolicy:
    state: RunState  # the history of evaluations, the best one and the wall time
    agent: TD3


def start_online_run(run: Run, info: EnvInfo, config: cfg.ExpertConfig | cfg.ImitationConfig, seed: int, *,
                     feature_width: int = 0) -> int:
    """What every online run does before it builds a network: go on from a resumed run's checkpoint, size the replay
    buffer (returned), and seed torch, so that the networks built next start from the seed's weights whatever the
    stage builds first (a resume then restores every generator)."""
    continue_run(run, config)
    capacity = replay_capacity(info, config, feature_width=feature_width)
    torch.manual_seed(seed)
    return capacity


def continue_run(run: Run, config: cfg.ExpertConfig | cfg.ImitationConfig) -> None:
    """Where a resumed run goes on from: a resume may raise the budget, or stop at the checkpoint's step, but not end
    before it; the curve loses the rows the killed process logged after its checkpoint. Nothing for a fresh run."""
    if run.resume is None:
        return
    reached = run.resume["run"]["step"]
    if reached > config.train.steps:
        raise LwailError(f"the checkpoint of {run.kind}/{run.name} is at step {reached}: --steps must be at least {reached}")
    run.write_log(learning_curve.FILE, run.resume["run"]["history"])


def replay_capacity(info: EnvInfo, config: cfg.ExpertConfig | cfg.ImitationConfig, *, feature_width: int = 0) -> int:
    """The replay buffer's capacity, refused up front if it would not fit in memory (``feature_width``: the floats
    the reward model caches per transition)."""
    capacity = min(config.td3.buffer_size, config.train.steps)
    floats = 2 * info.obs_dim + info.act_dim + 2 + feature_width  # s, a, s', r, not-done (+ cached features)
    require_memory(4 * capacity * floats, f"a replay buffer of {capacity} transitions")
    return capacity


def budget_warnings(config: cfg.ExpertConfig | cfg.ImitationConfig) -> list[str]:
    """What a budget too small to train or to watch a run leaves out. Warned, not refused: a short run that only
    checks the chain works is legitimate."""
    steps, td3, train = config.train.steps, config.td3, config.train
    warnings = []
    # an expert, or a method whose policy TD3 trains (BCO's cloned policy reads neither td3 setting)
    trains_td3 = getattr(config, "method", None) is None or METHODS[config.method].trains_td3
    if trains_td3 and steps < td3.learning_starts:
        warnings.append(f"--steps {steps} is below td3.learning_starts ({td3.learning_starts}): TD3 never updates, the policy "
                        "kept is its untrained initial network")
    elif trains_td3 and steps <= td3.random_steps:
        warnings.append(f"--steps {steps} is at most td3.random_steps ({td3.random_steps}): every action is uniformly random, "
                        "the policy kept never acted (raise --steps or lower --set td3.random_steps=N)")
    if train.eval_every > steps:
        warnings.append(f"--eval-every {train.eval_every} is above --steps {steps}: the policy is evaluated once, at the end")
    return warnings


def train_policy(hooks: Session, *, config: cfg.ExpertConfig | cfg.ImitationConfig, capacity: int,
                 reward_model: RewardModel | None = None) -> TrainedPolicy:
    """Build the agent and its buffer (torch seeded before, the reward model built after the seed) and train to
    ``config.train.steps``, checkpointing and logging each evaluation where ``hooks`` (``session``) say."""
    agent = TD3(hooks.info, config.td3, hooks.device, average_tau=config.train.average_tau)
    buffer = ReplayBuffer(capacity, hooks.info.obs_dim, hooks.info.act_dim, hooks.device)
    state = train_td3(
        hooks.info.id, agent, buffer, config.td3, config.train, hooks.seed, reward_model=reward_model, reference=hooks.reference,
        resume=hooks.resume, on_checkpoint=hooks.on_checkpoint, on_progress=hooks.on_progress,
        on_evaluation=hooks.on_evaluation, progress_every=hooks.progress_every, start_noise=config.env.start_noise,
        stop_requested=hooks.stop_requested,
    )
    return TrainedPolicy(state, agent)


def session(run: Run, *, info: EnvInfo, seed: int, device: torch.device, reference: Reference | None,
            on_progress: Progress | None) -> Session:
    """What an online loop in ``run`` reports to: checkpoints into the run, each evaluation to its learning curve,
    progress as ``run_summary`` figures; the checkpoint a resumed run goes on from, and whether it was asked to pause
    (``Run.pause_requested``)."""
    return Session(
        info=info, seed=seed, device=device, reference=reference, resume=run.resume, on_checkpoint=run.save_checkpoint,
        on_evaluation=lambda current: run.write_log(learning_curve.FILE, current.history),
        on_progress=None if on_progress is None else lambda step, current: on_progress(step, run_summary(current)),
        progress_every=PROGRESS_EVERY, stop_requested=run.pause_requested,
    )


WARNING = "warning"  # a line the caller prints once, beside the progress (not a figure)


def run_summary(run: RunState) -> dict:
    """The latest episode return, evaluation and score of a run in progress; at an evaluation's step, also that
    evaluation's whole row as ``curve/<column>`` (what a live logger records beside the CSV), and at the evaluation
    that judges it, the warning of a critic still saturated (``learning_curve.saturated_critic``)."""
    shown = {}
    if run.episode_returns:
        shown["ep_return"] = run.episode_returns[-1]
    if run.history:
        last = run.history[-1]
        shown["eval"] = last["return_mean"]
        if "normalized_score" in last:
            shown["score"] = last["normalized_score"]
        if last["step"] == run.step:
            shown.update({f"curve/{column}": value for column, value in last.items() if column != "step"})
            judged_now = len(run.history) == 1 or run.history[-2]["step"] < learning_curve.SATURATION_STEP
            note = learning_curve.saturated_critic(pd.DataFrame([last])) if judged_now else None
            if note is not None:
                shown[WARNING] = note
    return shown


def write_curve(path: Path, run: RunState) -> None:
    pd.DataFrame(run.history).to_csv(path, index=False)


def final_metrics(run: RunState, reference: Reference | None) -> dict:
    """The metrics every policy artifact ends with: its budget, wall time and last evaluation (and the reference)."""
    last = run.history[-1]
    metrics = {"env_steps": run.step, "wall_time_s": round(run.wall_time, 1), "return_mean": last["return_mean"], "return_std": last["return_std"]}
    if "normalized_score" in last:
        metrics["normalized_score"] = last["normalized_score"]
    if reference is not None:
        metrics["reference"] = reference.source
    return metrics
