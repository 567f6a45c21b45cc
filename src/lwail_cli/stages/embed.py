"""Stage: the state embedding φ — ICVF pre-trained on data set I, or the identity (the no-embedding ablation)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import config as cfg
from ..data import validate_episodes
from ..icvf import pretrain_icvf, probe_spearman, split_episodes
from .shared import Progress, default_name, load_dataset, save_weights

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store


def embed(
    store: Store, *, data_ref: str, config: cfg.EmbedConfig, seed: int, name: str | None = None, device: torch.device,
    on_progress: Progress | None = None,
) -> Artifact:
    dataset = store.resolve(data_ref, "dataset")
    info = dataset.env
    episodes = load_dataset(dataset)
    validate_episodes(episodes, info, f"dataset {dataset.ref}")
    name = name or default_name(info.id, config.kind)
    if config.kind == "identity":
        held_out = split_episodes(episodes, config.icvf.holdout_fraction, seed)[1]
        probe = probe_spearman(lambda x: x, held_out)
        record = {"type": "identity", "obs_dim": info.obs_dim, "embedding_dim": info.obs_dim}
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=[dataset]) as writer:
            writer.metrics.update({"probe_spearman": probe, "probe_spearman_raw": probe})
        return store.resolve(f"embedding/{name}", "embedding")
    result = pretrain_icvf(episodes, info.obs_dim, config.icvf, seed, device,
                           None if on_progress is None else lambda step, loss: on_progress(step, {"loss": loss}))
    record = {"type": "icvf", "obs_dim": info.obs_dim, "embedding_dim": config.icvf.embedding_dim, "icvf": cfg.to_dict(config.icvf)}
    with store.create("embedding", name, env=info, config=record, seed=seed, parents=[dataset]) as writer:
        save_weights(writer.path("phi.safetensors"), result.encoder.state_dict())
        result.log.to_csv(writer.path("loss.csv"), index=False)
        writer.metrics.update({"probe_spearman": result.probe_latent, "probe_spearman_raw": result.probe_raw, "final_loss": float(result.log["loss"].iloc[-1])})
    return store.resolve(f"embedding/{name}", "embedding")
