"""The whole chain on bundled demos in one call: demos → collect → embed → warmup → imitate → evaluate.

Every config of the chain is built (and so validated) before the first stage runs."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, ContextManager

from .. import config as cfg
from .chain import CHAIN, MAKES, run_stage
from .demos import bundled_demos_path, import_bundled_demos
from .evaluate import evaluate
from .shared import Progress

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

    def stages(self) -> list[tuple[str, object, int]]:
        """The chain's stages in order, each with its config and the work its progress bar counts."""
        return [("collect", self.collect, self.collect.transitions), ("pretrain-icvf", self.embed, self.embed.icvf.steps),
                ("warmup-disc", self.warmup, self.warmup.steps), ("imitate", self.imitation, self.imitation.train.steps)]


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
    made = {"demos": import_bundled_demos(store, env_id=env_id)}
    written(made["demos"])
    for number, (stage, config, total) in enumerate(plan.stages(), 1):
        with progress(f"{number}/{len(CHAIN)} {stage}", total) as report:
            made[MAKES[stage]] = run_stage(store, stage, made=made, env_id=env_id, config=config, seed=seed, device=device, on_progress=report)
        written(made[MAKES[stage]])
    return evaluate(store, policy_ref=made["policy"].ref, config=plan.evaluation, normalized=True)
