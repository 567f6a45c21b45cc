"""The whole chain on bundled demos in one call: demos → collect → embed → warmup → imitate → evaluate.

Its settings are declared as a sweep plan's are (``declaration.py``): every stage's defaults, the bundled preset's
table for the task (``quickstart.toml``: InvertedPendulum's minutes-long budgets), then the user's ``--set
STAGE:field=value``; every config of the chain is built (and so validated) before the first stage runs. The chain is
``chain.chain_for`` the imitation method, as a sweep's."""

from __future__ import annotations

from contextlib import nullcontext
from typing import TYPE_CHECKING, Callable, ContextManager

from ..errors import LwailError
from .chain import MAKES, chain_for, run_stage, work
from .declaration import PLAN_STAGES, preset, read_stage_assignments, stage_config
from .demos import bundled_demos_path, import_bundled_demos
from .evaluate import evaluate
from .shared import Progress

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store

QUICK_ENV = "InvertedPendulum-v5"


def quickstart_configs(env_id: str, overrides: list[str] = ()) -> dict[str, object]:
    """Each stage's config (eval's included), by stage: defaults, the preset's table for ``env_id``, then
    ``overrides`` (``STAGE:field=value``). Refuses a task without bundled demos and a setting for a stage the chain
    does not run, before any work."""
    bundled_demos_path(env_id)
    given = read_stage_assignments(list(overrides))
    table = preset(env_id)
    configs = {stage: stage_config(stage, table.get(stage, ()), given.get(stage, ())) for stage in PLAN_STAGES}
    unread = sorted(set(given) - {*chain_for(configs["imitate"].method), "eval"})
    if unread:
        raise LwailError(f"--set {unread[0]}:...: the method {configs['imitate'].method} runs no {unread[0]} stage")
    return configs


# Given a stage's label and total, a context yielding the callback that stage reports its progress to.
StageProgress = Callable[[str, int], ContextManager[Progress]]


def quickstart(
    store: Store, *, env_id: str, configs: dict[str, object], seed: int, device: torch.device,
    progress: StageProgress | None = None, on_written: Callable[[Artifact], None] | None = None,
) -> dict:
    """Run the chain on ``configs`` (``quickstart_configs``); returns the final evaluation."""
    progress = progress or (lambda label, total: nullcontext(None))
    written = on_written or (lambda artifact: None)
    made = {"demos": import_bundled_demos(store, env_id=env_id)}
    written(made["demos"])
    chain = chain_for(configs["imitate"].method)
    for number, stage in enumerate(chain, 1):
        with progress(f"{number}/{len(chain)} {stage}", work(stage, configs[stage])) as report:
            made[MAKES[stage]] = run_stage(store, stage, made=made, env_id=env_id, config=configs[stage], seed=seed, device=device,
                                           on_progress=report)
        written(made[MAKES[stage]])
    return evaluate(store, policy_ref=made["policy"].ref, config=configs["eval"], normalized=True)
