"""The whole chain on bundled demos in one call: demos → collect → embed → warmup → imitate → evaluate.

Every config of the chain is built (and so validated) before the first stage runs."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, ContextManager

from .. import config as cfg
from .collect import collect
from .demos import bundled_demos_path, import_bundled_demos
from .embed import embed
from .evaluate import evaluate
from .imitate import imitate
from .shared import Progress
from .warmup import warmup

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store

QUICK_ENV = "InvertedPendulum-v5"
QUICK_STEPS = 25_000  # TD3 balances after a plateau at returns ~50-100 that lasts 10-20k steps


@dataclass(frozen=True)
class QuickstartPlan:
    collect: cfg.CollectConfig
    embed: cfg.EmbedConfig
    warmup: cfg.WarmupConfig
    imitation: cfg.ImitationConfig
    evaluation: cfg.EvalConfig


def quickstart_plan(env_id: str, steps: int | None) -> QuickstartPlan:
    """Budgets for the one-command demo: minutes on a 2-core CPU for InvertedPendulum, paper budgets otherwise."""
    bundled_demos_path(env_id)  # refuses an env without bundled demos before any work
    if env_id == QUICK_ENV:
        steps = QUICK_STEPS if steps is None else steps
        return QuickstartPlan(
            collect=cfg.CollectConfig(),
            embed=cfg.EmbedConfig(icvf=cfg.ICVFConfig(steps=1_000, log_every=250)),
            warmup=cfg.WarmupConfig(steps=500),
            imitation=cfg.ImitationConfig(
                td3=cfg.TD3Config(random_steps=2_000, learning_starts=2_000),
                train=cfg.TrainConfig(steps=steps, eval_every=max(1, steps // 5), checkpoint_every=steps),
                update_every=2_000,
            ),
            evaluation=cfg.EvalConfig(),
        )
    steps = 1_000_000 if steps is None else steps
    return QuickstartPlan(
        collect=cfg.CollectConfig(),
        embed=cfg.EmbedConfig(),
        warmup=cfg.WarmupConfig(),
        imitation=cfg.ImitationConfig(train=cfg.TrainConfig(steps=steps, eval_every=min(10_000, steps))),
        evaluation=cfg.EvalConfig(),
    )


# Given a stage's label and total, a context yielding the callback that stage reports its progress to.
StageProgress = Callable[[str, int], ContextManager[Progress]]


def quickstart(
    store: Store, *, env_id: str, plan: QuickstartPlan, seed: int, device: torch.device,
    progress: StageProgress | None = None, on_written: Callable[[Artifact], None] | None = None,
) -> dict:
    """Run the chain; returns the final evaluation."""
    progress = progress or (lambda label, total: nullcontext(None))
    written = on_written or (lambda artifact: None)
    demos = import_bundled_demos(store, env_id=env_id)
    written(demos)
    with progress("1/4 collect", plan.collect.transitions) as report:
        data = collect(store, env_id=env_id, config=plan.collect, seed=seed, on_progress=report)
    written(data)
    with progress("2/4 pretrain-icvf", plan.embed.icvf.steps) as report:
        embedding = embed(store, data_ref=data.ref, config=plan.embed, seed=seed, device=device, demos_ref=demos.ref, on_progress=report)
    written(embedding)
    with progress("3/4 warmup-disc", plan.warmup.steps) as report:
        disc = warmup(store, embedding_ref=embedding.ref, demos_ref=demos.ref, config=plan.warmup, seed=seed, device=device, on_progress=report)
    written(disc)
    with progress("4/4 imitate", plan.imitation.train.steps) as report:
        policy = imitate(store, env_id=env_id, demos_ref=demos.ref, embedding_ref=embedding.ref, disc_ref=disc.ref,
                         config=plan.imitation, seed=seed, device=device, on_progress=report)
    written(policy)
    return evaluate(store, policy_ref=policy.ref, config=plan.evaluation, normalized=True)
