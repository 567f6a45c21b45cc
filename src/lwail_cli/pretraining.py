"""The loop every trained embedding shares: gradient steps on batches of data set I, a logged loss and quality probe,
checkpoints, and a resume that continues bit for bit. An embedding brings its learner and its sampler (``icvf.py``,
``contrastive.py``); this module never knows which one it trains."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import pandas as pd
import torch

from .data import Episode
from .errors import RunPaused
from .nets import Encoder
from .probes import probe_critic_needs, probe_spearman
from .resumable import Stopwatch, capture, checkpoint_due, restore


class Learner(Protocol):
    def update(self, batch: dict[str, torch.Tensor]) -> torch.Tensor: ...  # one gradient step; its loss, detached

    def encoder(self) -> Encoder: ...  # the current φ, frozen, on the CPU

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


class Schedule(Protocol):
    """The settings of the loop (every trained embedding's config has them)."""

    steps: int
    batch_size: int
    log_every: int
    checkpoint_every: int


@dataclass
class EmbeddingResult:
    encoder: Encoder
    log: pd.DataFrame  # step, wall_time, loss, probe_latent (and separation_auc, progress_spearman given the expert)
    probe_latent: float
    probe_raw: float


def pretrain(
    learner: Learner,
    sample: Callable[[int], dict[str, torch.Tensor]],
    schedule: Schedule,
    held_out: list[Episode],
    device: torch.device | str,
    on_progress: Callable[[int, float | None], None] | None = None,
    resume: dict | None = None,
    on_checkpoint: Callable[[dict], None] | None = None,
    expert: list[Episode] | None = None,
    stop_requested: Callable[[], bool] | None = None,
) -> EmbeddingResult:
    """``schedule.steps`` updates on ``sample(batch_size)``, reporting every step to ``on_progress`` (with the mean loss
    since the last logged step at a logged one, else None); every ``schedule.checkpoint_every`` steps
    ``on_checkpoint`` gets the whole state (``resumable.capture``), and ``resume`` (such a state) continues bit for
    bit. After every step ``stop_requested`` is asked (a step is ~0.1 s, a question a file's existence): when it says
    so the run checkpoints there and raises ``RunPaused``. Every log row probes φ on the ``held_out`` episodes and,
    given the ``expert`` episodes, what the critic needs (``probes.probe_critic_needs``), so one long run shows which
    budget φ needs."""
    parts = {"learner": learner}
    rows, running, first, clock = [], torch.zeros((), device=device), 1, Stopwatch()
    if resume is not None:
        restore(resume, parts)
        rows, first, clock = list(resume["rows"]), resume["step"] + 1, Stopwatch(resume["wall_time"])
        running = resume["running"].to(device)
    for step in range(first, schedule.steps + 1):
        running += learner.update(sample(schedule.batch_size))
        logged = None
        if step % schedule.log_every == 0 or step == schedule.steps:
            span = step - (rows[-1]["step"] if rows else 0)  # the steps ``running`` summed: a resume may change log_every
            encoder = learner.encoder()
            loss = running.item() / span
            rows.append({"step": step, "wall_time": clock.elapsed(), "loss": loss, "probe_latent": probe_spearman(encoder, held_out)}
                        | ({} if expert is None else probe_critic_needs(encoder, expert, held_out)))
            running.zero_()
            logged = loss
        if on_progress is not None:
            on_progress(step, logged)
        stop = stop_requested is not None and step < schedule.steps and stop_requested()
        if on_checkpoint is not None and (stop or checkpoint_due(step, schedule.checkpoint_every, schedule.steps)):
            on_checkpoint(capture(parts, rows=list(rows), step=step, wall_time=clock.elapsed(), running=running.detach().cpu().clone()))
        if stop:
            raise RunPaused(step)
    encoder = learner.encoder()
    return EmbeddingResult(encoder, pd.DataFrame(rows), probe_spearman(encoder, held_out), probe_spearman(lambda x: x, held_out))
