"""Stage: LWAIL — TD3 on the pseudo-reward σ(−f(φ(s), φ(s'))), f updated online from the warmed-up critic."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import config as cfg
from ..discriminator import DiscriminatorTrainer
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..imitation import AdversarialReward
from .shared import (
    PolicyRun,
    Progress,
    critic_config,
    default_name,
    expert_pairs,
    load_critic,
    load_encoder,
    pair_features,
    reference_for_env,
    save_weights,
    train_policy,
    write_history,
)

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store
    from ..evaluation import Reference
    from ..training import RunState


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
    disc_embedding = next(p for p in disc.manifest["parents"] if p["ref"].startswith("embedding/"))
    if disc_embedding["hash"] != embedding.hash:
        raise LwailError(
            f"{disc.ref} was warmed up on {disc_embedding['ref']} ({disc.config['embedding_type']}), "
            f"not on {embedding.ref} ({embedding.config['type']}): warm up a discriminator on this embedding"
        )
    critic = critic_config(disc)  # f keeps the loss and learning rate it was warmed up with
    expert_states = expert_pairs(demos, config.expert_episodes)
    reference = reference_for_env(env_id, demos)

    def reward_model(capacity: int) -> AdversarialReward:
        encoder = load_encoder(embedding, device)
        expert = pair_features(encoder, *expert_states, device)
        trainer = DiscriminatorTrainer(load_critic(disc, device), critic)
        return AdversarialReward(encoder, trainer, expert, capacity, update_every=config.update_every, update_steps=config.update_steps)

    def write(writer, result, agent, rewards: AdversarialReward) -> None:
        save_weights(writer.path("actor.safetensors"), agent.actor.state_dict())
        save_weights(writer.path("critic.safetensors"), rewards.trainer.critic.state_dict())
        write_history(writer.path("learning_curve.csv"), result)
        _plot_run(writer, result, env_id, reference)

    run = PolicyRun(
        env_id=env_id, name=name or default_name(env_id, "lwail"), config=config, seed=seed, parents=[demos, embedding, disc],
        trained_on="LWAIL pseudo-reward", reference=reference, reward_model=reward_model, write=write,
        recorded={**cfg.to_dict(config), "critic": cfg.to_dict(critic)},
    )
    return train_policy(store, run, device=device, resume=resume, on_progress=on_progress)


def _plot_run(writer, run: RunState, env_id: str, reference: Reference | None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    history = pd.DataFrame(run.history)
    score = "normalized_score" if reference is not None else "return_mean"
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(history["step"], history[score], marker="o")
    ax.set(xlabel="environment steps", ylabel=score.replace("_", " "), title=f"LWAIL on {env_id}")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(writer.path("learning_curve.png"), dpi=100)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 4))
    points = ax.scatter(history["pseudo_reward_mean"], history["return_mean"], c=history["step"], cmap="viridis")
    fig.colorbar(points, label="environment steps")
    ax.set(xlabel="mean pseudo-reward σ(−f) of recent transitions", ylabel="true return", title="pseudo-reward vs true return")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(writer.path("pseudo_reward_vs_return.png"), dpi=100)
    plt.close(fig)
