"""Stage: the state embedding φ — ICVF pre-trained on data set I, or the identity (the no-embedding ablation)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import config as cfg
from ..data import validate_episodes
from ..envs import require_same_env
from ..icvf import probe_critic_needs, pretrain_icvf, probe_spearman, split_episodes
from ..loaders import load_dataset, load_demos, save_weights
from ..runs import open_run, run_record
from .shared import Progress, default_name

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store


def embed(
    store: Store, *, data_ref: str, config: cfg.EmbedConfig, seed: int, name: str | None = None, device: torch.device,
    demos_ref: str | None = None, on_progress: Progress | None = None, resume: bool = False,
) -> Artifact:
    """φ from data set I; with ``demos_ref``, also probe what the critic needs (expert vs random separation,
    progress along the expert trajectory) for φ and for raw states. The probes never train anything."""
    dataset = store.resolve(data_ref, "dataset")
    info = dataset.env
    demos = store.resolve(demos_ref, "demos") if demos_ref else None
    if demos is not None:
        require_same_env(info, demos.env, f"demos {demos.ref}")
    episodes = load_dataset(dataset)
    validate_episodes(episodes, info, f"dataset {dataset.ref}")
    name = name or default_name(info.id, config.kind)
    held_out = split_episodes(episodes, config.icvf.holdout_fraction, seed)[1]
    expert = None if demos is None else load_demos(demos)[0]

    def critic_probe(encode, suffix: str) -> dict:
        if expert is None:
            return {}
        found = probe_critic_needs(encode, expert, held_out)
        return {f"probe_{key}{suffix}": value for key, value in found.items()}

    raw = critic_probe(lambda x: x, "_raw")
    parents = [dataset] + ([demos] if demos is not None else [])
    if config.kind == "identity":
        probe = probe_spearman(lambda x: x, held_out)
        record = {"type": "identity", "obs_dim": info.obs_dim, "embedding_dim": info.obs_dim}
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=parents) as writer:
            writer.metrics.update({"probe_spearman": probe, "probe_spearman_raw": probe} | critic_probe(lambda x: x, "") | raw)
        return writer.artifact
    record = {"type": "icvf", "obs_dim": info.obs_dim, "embedding_dim": config.icvf.embedding_dim, "icvf": cfg.to_dict(config.icvf)}
    with open_run(store, "embedding", name, resume=resume, record=run_record(record, seed, info.id, parents), config_class=cfg.EmbedConfig) as run:
        result = pretrain_icvf(episodes, info.obs_dim, config.icvf, seed, device,
                               None if on_progress is None else lambda step, loss: on_progress(step, {} if loss is None else {"loss": loss}),
                               resume=run.resume, on_checkpoint=run.save_checkpoint, expert=expert)
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=parents) as writer:
            save_weights(writer.path("phi.safetensors"), result.encoder.state_dict())
            result.log.to_csv(writer.path("loss.csv"), index=False)
            writer.metrics.update({"probe_spearman": result.probe_latent, "probe_spearman_raw": result.probe_raw, "final_loss": float(result.log["loss"].iloc[-1])})
            writer.metrics.update(critic_probe(result.encoder, "") | raw)
    return writer.artifact
