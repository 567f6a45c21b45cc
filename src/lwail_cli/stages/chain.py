"""The chain of LWAIL's stages, each run on the artifacts made before it: what `quickstart` and `sweep` both run.

With ``stages/quickstart.py`` and ``stages/sweep.py`` (and its plan, ``sweep_plan.py``), its only users, the one module
that imports other stages.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..embeddings import embedding
from ..methods import METHODS
from .collect import collect
from .embed import embed
from .imitate import imitate
from .warmup import warmup

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store
    from .shared import Progress

CHAIN = ("collect", "pretrain-icvf", "warmup-disc", "imitate")  # each a command of config.STAGES
MAKES = {"collect": "dataset", "pretrain-icvf": "embedding", "warmup-disc": "discriminator", "imitate": "policy"}
READS = {  # the artifacts (by kind) each stage reads, in the order a sweep fingerprints them
    "collect": (),
    "pretrain-icvf": ("dataset", "demos"),
    "warmup-disc": ("embedding", "demos"),
    "imitate": ("demos", "embedding", "discriminator"),  # the discriminator only for a method that reads one
}


def chain_for(method: str) -> tuple[str, ...]:
    """The stages of ``CHAIN`` a run of the imitation ``method`` needs: warmup-disc only if the method reads f."""
    return tuple(stage for stage in CHAIN if stage != "warmup-disc" or METHODS[method].reads_discriminator)


def reads(stage: str, method: str) -> tuple[str, ...]:
    """The artifact kinds ``stage`` reads in a run of ``method`` (``READS`` less what the chain does not make)."""
    made = {MAKES[before] for before in chain_for(method)} | {"demos"}
    return tuple(kind for kind in READS[stage] if kind in made)


def work(stage: str, config) -> int:
    """What the stage's progress bar counts: transitions collected, φ's gradient steps, f's warm-up steps, env steps."""
    if stage == "pretrain-icvf":
        settings = embedding(config.kind).settings(config)
        return settings.steps if settings is not None else 0
    if stage == "collect":
        return config.transitions
    return config.steps if stage == "warmup-disc" else config.train.steps


def run_stage(
    store: Store, stage: str, *, made: dict[str, Artifact], env_id: str, config, seed: int, device: torch.device | None = None,
    name: str | None = None, resume: bool = False, on_progress: Progress | None = None,
) -> Artifact:
    """One stage of ``CHAIN`` on the artifacts ``made`` before it (by kind, the bundled ``demos`` among them)."""
    if stage == "collect":
        return collect(store, env_id=env_id, config=config, seed=seed, name=name, on_progress=on_progress)
    if stage == "pretrain-icvf":
        return embed(store, data_ref=made["dataset"].ref, config=config, seed=seed, name=name, device=device,
                     demos_ref=made["demos"].ref, on_progress=on_progress, resume=resume)
    if stage == "warmup-disc":
        return warmup(store, embedding_ref=made["embedding"].ref, demos_ref=made["demos"].ref, config=config, seed=seed,
                      name=name, device=device, on_progress=on_progress)
    if stage == "imitate":
        disc = made["discriminator"] if METHODS[config.method].reads_discriminator else None
        return imitate(store, env_id=env_id, demos_ref=made["demos"].ref, embedding_ref=made["embedding"].ref,
                       disc_ref=disc.ref if disc else None, config=config, seed=seed, name=name, device=device, resume=resume,
                       on_progress=on_progress)
    raise ValueError(f"{stage} is not a stage of the chain {CHAIN}")
