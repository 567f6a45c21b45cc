"""Stage: LWAIL — TD3 on the pseudo-reward σ(−f(φ(s), φ(s'))), f updated online from the warmed-up critic."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

from .. import config as cfg
from ..data import transition_pairs
from ..discriminator import DiscriminatorTrainer
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..imitation import AdversarialReward
from .plots import plot_run
from .shared import (
    PolicyRun,
    Progress,
    critic_config,
    default_name,
    expert_pairs,
    load_critic,
    load_dataset,
    load_encoder,
    pair_features,
    parent,
    reference_for_env,
    save_weights,
    train_policy,
)

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store

DIAGNOSTIC_PAIRS = 4_000  # random-policy pairs of data set I whose reward is logged at each evaluation


def imitate(
    store: Store, *, env_id: str, demos_ref: str, embedding_ref: str, disc_ref: str, config: cfg.ImitationConfig, seed: int,
    name: str | None = None, device: torch.device, resume: bool = False, on_progress: Progress | None = None,
) -> Artifact:
    info = describe_env(env_id)
    demos = store.resolve(demos_ref, "demos")
    embedding = store.resolve(embedding_ref, "embedding")
    disc = store.resolve(disc_ref, "discriminator")
    for artifact in (demos, embedding, disc):
        require_same_env(info, artifact.env, f"{artifact.kind} {artifact.ref}")
    disc_embedding = parent(store, disc, "embedding")
    if disc_embedding.hash != embedding.hash:
        raise LwailError(
            f"{disc.ref} was warmed up on {disc_embedding.ref} ({disc.config['embedding_type']}), "
            f"not on {embedding.ref} ({embedding.config['type']}): warm up a discriminator on this embedding"
        )
    critic = critic_config(disc)  # f keeps the loss and learning rate it was warmed up with
    expert_states = expert_pairs(demos, config.expert_episodes)
    random_states = tuple(pairs[:DIAGNOSTIC_PAIRS] for pairs in transition_pairs(load_dataset(parent(store, disc, "dataset"))))
    reference = reference_for_env(env_id, demos)

    def reward_model(capacity: int) -> AdversarialReward:
        encoder = load_encoder(embedding, device)
        expert = pair_features(encoder, *expert_states, device)
        trainer = DiscriminatorTrainer(load_critic(disc, device), critic)
        return AdversarialReward(encoder, trainer, expert, capacity, update_every=config.update_every, update_steps=config.update_steps,
                                 random_features=pair_features(encoder, *random_states, device))

    def write(writer, result, agent, rewards: AdversarialReward) -> None:
        save_weights(writer.path("actor.safetensors"), agent.network(config.train.policy).state_dict())
        save_weights(writer.path("critic.safetensors"), rewards.trainer.critic.state_dict())
        plot_run(pd.DataFrame(result.history), writer.path("learning_curve.png"), writer.path("pseudo_reward_vs_return.png"), f"LWAIL on {env_id}")

    run = PolicyRun(
        env_id=env_id, name=name or default_name(env_id, "lwail"), config=config, seed=seed, parents=[demos, embedding, disc],
        trained_on="LWAIL pseudo-reward", reference=reference, reward_model=reward_model, write=write,
        recorded={**cfg.to_dict(config), "critic": cfg.to_dict(critic)}, feature_width=disc.config["input_dim"],
    )
    return train_policy(store, run, device=device, resume=resume, on_progress=on_progress)
