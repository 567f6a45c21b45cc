"""Stage: warm the critic f up — expert pairs vs true (s, s') pairs of the random policy (data set I)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from .. import config as cfg
from .. import learning_curve
from ..data import transition_pairs
from ..discriminator import Critic, DiscriminatorTrainer
from ..envs import require_same_env
from ..loaders import load_dataset, load_encoder, parent, save_weights
from .shared import Progress, expert_pairs, pair_features

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store

PROGRESS_REPORTS = 50  # f trains in this many chunks so the caller can show progress


def warmup(
    store: Store, *, embedding_ref: str, demos_ref: str, config: cfg.WarmupConfig, seed: int, name: str | None = None,
    device: torch.device, data_ref: str | None = None, on_progress: Progress | None = None,
) -> Artifact:
    embedding = store.resolve(embedding_ref, "embedding")
    demos = store.resolve(demos_ref, "demos")
    info = embedding.env
    require_same_env(info, demos.env, f"demos {demos.ref}")
    dataset = store.resolve(data_ref, "dataset") if data_ref else parent(store, embedding, "dataset")
    require_same_env(info, dataset.env, f"dataset {dataset.ref}")
    expert_states = expert_pairs(demos, config.expert_episodes)
    torch.manual_seed(seed)
    encoder = load_encoder(embedding, device)
    states, next_states = transition_pairs(load_dataset(dataset))
    pick = np.random.default_rng(seed).permutation(len(states))[: config.transitions]
    expert = pair_features(encoder, *expert_states, device)
    policy = pair_features(encoder, states[pick], next_states[pick], device)
    critic = Critic(expert.shape[1], config.critic.hidden, standardize=config.critic.standardize).to(device)
    if config.critic.standardize:  # statistics of all of data set I, not only the pairs f is warmed up against
        critic.fit_standardization(pair_features(encoder, states, next_states, device))
    trainer = DiscriminatorTrainer(critic, config.critic)
    chunk = max(1, config.steps // PROGRESS_REPORTS)
    for done in range(0, config.steps, chunk):
        steps = min(chunk, config.steps - done)
        wasserstein = trainer.train(expert, policy, steps)
        if on_progress is not None:
            on_progress(done + steps, {"wasserstein": float(wasserstein)})
    name = name or f"{embedding.name}-disc"
    record = {**cfg.to_dict(config), "embedding_type": embedding.config["type"], "input_dim": expert.shape[1]}
    with store.create("discriminator", name, env=info, config=record, seed=seed, parents=[embedding, demos, dataset]) as writer:
        save_weights(writer.path("critic.safetensors"), critic.state_dict())
        writer.metrics.update({
            learning_curve.WASSERSTEIN: float(wasserstein),
            learning_curve.REWARD_EXPERT: float(trainer.reward(expert).mean()),
            learning_curve.REWARD_RANDOM: float(trainer.reward(policy).mean()),
        })
    return writer.artifact
