"""Stage: LWAIL — TD3 on the pseudo-reward σ(−f(φ(s), φ(s'))), f updated online from the warmed-up critic."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

from .. import config as cfg
from .. import learning_curve
from ..data import transition_pairs
from ..discriminator import DiscriminatorTrainer
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..imitation import AdversarialReward
from ..loaders import critic_config, load_critic, load_dataset, load_encoder, parent, save_weights
from ..plots import plot_run
from ..runs import open_run, run_record
from .online import final_metrics, start_online_run, train_policy, write_curve
from .shared import Progress, default_name, expert_pairs, pair_features, reference_for_env

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
    name = name or default_name(env_id, "lwail")
    parents = [demos, embedding, disc]
    record = {**cfg.to_dict(config), "critic": cfg.to_dict(critic)}
    with open_run(store, "policy", name, resume=resume, record=run_record(record, seed, env_id, parents), config_class=cfg.ImitationConfig) as run:
        capacity = start_online_run(run, info, config, seed, feature_width=disc.config["input_dim"])  # then φ and f (their
        # initial weights replaced by their artifacts') draw from torch's generator before the agent does
        encoder = load_encoder(embedding, device)
        expert = pair_features(encoder, *expert_states, device)
        trainer = DiscriminatorTrainer(load_critic(disc, device), critic)
        reward_model = AdversarialReward(encoder, trainer, expert, capacity, update_every=config.update_every, update_steps=config.update_steps,
                                         random_features=pair_features(encoder, *random_states, device))
        trained = train_policy(run, info=info, config=config, seed=seed, capacity=capacity, device=device,
                               reward_model=reward_model, reference=reference, on_progress=on_progress)
        with store.create("policy", name, env=info, config=record, seed=seed, parents=parents, extra={"trained_on": "LWAIL pseudo-reward"}) as writer:
            write_curve(writer.path(learning_curve.FILE), trained.state)
            save_weights(writer.path("actor.safetensors"), trained.agent.network(config.train.policy).state_dict())
            save_weights(writer.path("critic.safetensors"), reward_model.trainer.critic.state_dict())
            plot_run(pd.DataFrame(trained.state.history), writer.path("learning_curve.png"), writer.path("pseudo_reward_vs_return.png"),
                     f"LWAIL on {env_id}")
            writer.metrics.update(final_metrics(trained.state, reference))
    return writer.artifact
