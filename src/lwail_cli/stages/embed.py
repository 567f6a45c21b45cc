"""Stage: the state embedding φ of the kind ``embed.kind`` names (``embeddings.EMBEDDINGS``), trained on data set I, or
the identity (the no-embedding ablation)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import config as cfg
from ..data import validate_episodes
from ..embeddings import embedding
from ..envs import require_same_env
from ..loaders import load_dataset, load_demos, save_weights
from ..probes import probe_critic_needs, probe_spearman, split_episodes
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
    entry = embedding(config.kind)
    held_out = split_episodes(episodes, getattr(config, entry.own_section()).holdout_fraction, seed)[1]
    expert = None if demos is None else load_demos(demos)[0]

    def critic_probe(encode, suffix: str) -> dict:
        if expert is None:
            return {}
        found = probe_critic_needs(encode, expert, held_out)
        return {f"probe_{key}{suffix}": value for key, value in found.items()}

    raw = critic_probe(lambda x: x, "_raw")
    parents = [dataset] + ([demos] if demos is not None else [])
    record = entry.record(config, info.obs_dim)
    if not entry.trained:
        probe = probe_spearman(lambda x: x, held_out)
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=parents) as writer:
            writer.metrics.update({"probe_spearman": probe, "probe_spearman_raw": probe} | critic_probe(lambda x: x, "") | raw)
        return writer.artifact
    with open_run(store, "embedding", name, resume=resume, record=run_record(record, seed, info.id, parents), config_class=cfg.EmbedConfig) as run:
        result = entry.pretrain(episodes, info.obs_dim, entry.settings(config), seed, device,
                                on_progress=None if on_progress is None else lambda step, loss: on_progress(step, {} if loss is None else {"loss": loss}),
                                resume=run.resume, on_checkpoint=run.save_checkpoint, expert=expert,
                                stop_requested=run.pause_requested)
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=parents) as writer:
            save_weights(writer.path("phi.safetensors"), result.encoder.state_dict())
            result.log.to_csv(writer.path("loss.csv"), index=False)
            writer.metrics.update({"probe_spearman": result.probe_latent, "probe_spearman_raw": result.probe_raw, "final_loss": float(result.log["loss"].iloc[-1])})
            writer.metrics.update(critic_probe(result.encoder, "") | raw)
    return writer.artifact
