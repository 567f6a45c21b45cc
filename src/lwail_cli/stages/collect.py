"""Stage: state-only data set I — a uniformly random policy's episodes, or imported ones — as a Minari dataset."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import config as cfg
from ..config import CollectConfig
from ..data import Episode
from ..envs import describe_env, make_env
from ..formats.minari_hdf5 import write_minari
from ..formats.npz import npz_load_bytes
from ..rollout import rollout
from ..seeds import stream_seeds
from .shared import Progress, default_name, read_external, require_memory

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store


def collect(
    store: Store, *, env_id: str, config: CollectConfig, seed: int, name: str | None = None, on_progress: Progress | None = None
) -> Artifact:
    info = describe_env(env_id)
    # recorded steps are per-step arrays in Python lists, then copied into Minari's format: ~3 float64 copies + object overhead
    require_memory(config.transitions * (3 * 8 * (info.obs_dim + info.act_dim + 1) + 400), f"collecting {config.transitions} transitions")
    episodes = rollout(env_id, None, stream_seeds(seed, "collect"), record=True, transitions=config.transitions,
                       on_step=None if on_progress is None else lambda done: on_progress(done, {}), start_noise=config.env.start_noise).episodes
    name = name or default_name(env_id, "random")
    return _write(store, name, info, episodes, {"source": "uniform-random", **cfg.to_dict(config)}, seed,
                  "uniform-random", "uniform-random policy, state-only use", {})


def import_dataset(store: Store, *, env_id: str, name: str | None = None, minari_id: str | None = None, npz: Path | None = None) -> Artifact:
    info = describe_env(env_id)
    if npz is not None:
        require_memory(npz_load_bytes(npz), f"loading {npz}")
    episodes, source, extra = read_external(info, minari_id=minari_id, npz=npz)
    name = name or default_name(env_id, "imported")
    for episode in episodes:  # a state-only file has neither; Minari's format needs both
        n = episode.length
        episode.actions = episode.actions if episode.actions is not None else np.full((n, info.act_dim), np.nan, np.float32)
        episode.rewards = episode.rewards if episode.rewards is not None else np.full(n, np.nan, np.float32)
    return _write(store, name, info, episodes, {"source": source}, None, source, f"imported from {source}", extra)


def _write(store, name, info, episodes: list[Episode], config: dict, seed, source: str, description: str, extra: dict) -> Artifact:
    env = make_env(info.id)  # Minari records the spaces from a real env of the registered id
    try:
        with store.create("dataset", name, env=info, config=config, seed=seed) as writer:
            write_minari(episodes, writer.path("minari"), f"lwail/{name}-v0", env, source, description)
            writer.metrics.update(_episode_metrics(episodes) | extra)
    finally:
        env.close()
    return writer.artifact


def _episode_metrics(episodes: list[Episode]) -> dict:
    returns = [e.episode_return for e in episodes if e.rewards is not None and np.all(np.isfinite(e.rewards))]
    metrics = {
        "episodes": len(episodes),
        "transitions": int(sum(e.length for e in episodes)),
        "terminations": int(sum(e.terminated for e in episodes)),
    }
    if returns:
        metrics["mean_return"] = float(np.mean(returns))
    return metrics
