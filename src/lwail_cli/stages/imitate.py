"""Stage: imitation — TD3 on the reward of an imitation method (``methods.METHODS``: LWAIL's σ(−f(φ(s), φ(s'))), f
updated online from the warmed-up critic, or a baseline), all on the same φ, demo, seeds and evaluation."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

from .. import config as cfg
from .. import learning_curve
from ..data import transition_pairs
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..loaders import critic_config, load_critic, load_dataset, load_encoder, parent, save_weights
from ..methods import METHODS, Inputs, Method
from ..plots import plot_run
from ..runs import open_run, run_record
from .online import final_metrics, start_online_run, train_policy, write_curve
from .shared import Progress, default_name, expert_pairs, pair_features, reference_for_env

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store

DIAGNOSTIC_PAIRS = 4_000  # random-policy pairs of data set I whose reward is logged at each evaluation


def imitate(
    store: Store, *, env_id: str, demos_ref: str, embedding_ref: str, disc_ref: str | None = None, config: cfg.ImitationConfig,
    seed: int, name: str | None = None, device: torch.device, resume: bool = False, on_progress: Progress | None = None,
) -> Artifact:
    method = METHODS[config.method]
    info = describe_env(env_id)
    demos = store.resolve(demos_ref, "demos")
    embedding = store.resolve(embedding_ref, "embedding")
    disc = _discriminator(store, method, disc_ref, embedding)
    for artifact in (demos, embedding) + ((disc,) if disc else ()):
        require_same_env(info, artifact.env, f"{artifact.kind} {artifact.ref}")
    critic = critic_config(disc) if disc else None  # f keeps the loss and learning rate it was warmed up with
    expert_states = expert_pairs(demos, config.expert_episodes)
    # the random-policy pairs f was warmed up against (LWAIL), else those φ was trained on
    random_states = tuple(pairs[:DIAGNOSTIC_PAIRS] for pairs in transition_pairs(load_dataset(parent(store, disc or embedding, "dataset"))))
    reference = reference_for_env(env_id, demos)
    name = name or default_name(env_id, config.method)
    parents = [demos, embedding] + ([disc] if disc else [])
    record = cfg.to_dict(config) | ({"critic": cfg.to_dict(critic)} if critic else {})
    with open_run(store, "policy", name, resume=resume, record=run_record(record, seed, env_id, parents), config_class=cfg.ImitationConfig) as run:
        width = (disc.config["input_dim"] if disc else 2 * load_encoder(embedding).dim) if method.caches_features else 0
        capacity = start_online_run(run, info, config, seed, feature_width=width)  # then φ and the method's networks
        # (a warmed-up f's initial weights replaced by its artifact's) draw from torch's generator before the agent does
        encoder = load_encoder(embedding, device)
        reward_model = method.build(Inputs(
            config=config, encoder=encoder, expert=pair_features(encoder, *expert_states, device),
            random=pair_features(encoder, *random_states, device), capacity=capacity,
            critic=load_critic(disc, device) if disc else None, critic_config=critic,
        ))
        trained = train_policy(run, info=info, config=config, seed=seed, capacity=capacity, device=device,
                               reward_model=reward_model, reference=reference, on_progress=on_progress)
        with store.create("policy", name, env=info, config=record, seed=seed, parents=parents, extra={"trained_on": method.trained_on}) as writer:
            write_curve(writer.path(learning_curve.FILE), trained.state)
            save_weights(writer.path("actor.safetensors"), trained.agent.network(config.train.policy).state_dict())
            for filename, weights in reward_model.weights().items():
                save_weights(writer.path(filename), weights)
            plot_run(pd.DataFrame(trained.state.history), writer.path("learning_curve.png"), writer.path("pseudo_reward_vs_return.png"),
                     f"{method.label} on {env_id}", method.reward)
            writer.metrics.update(final_metrics(trained.state, reference))
    return writer.artifact


def _discriminator(store: Store, method: Method, disc_ref: str | None, embedding: Artifact) -> Artifact | None:
    """The warmed-up discriminator a method reads (checked against the embedding), or None; one line for a method
    given one it ignores, or not given one it needs."""
    if not method.reads_discriminator:
        if disc_ref is not None:
            raise LwailError(f"--method {method.name} trains no warmed-up discriminator: drop --disc {disc_ref}")
        return None
    if disc_ref is None:
        raise LwailError(f"--method {method.name} needs a warmed-up discriminator: give --disc REF (from `lwail warmup-disc`)")
    disc = store.resolve(disc_ref, "discriminator")
    disc_embedding = parent(store, disc, "embedding")
    if disc_embedding.hash != embedding.hash:
        raise LwailError(
            f"{disc.ref} was warmed up on {disc_embedding.ref} ({disc.config['embedding_type']}), "
            f"not on {embedding.ref} ({embedding.config['type']}): warm up a discriminator on this embedding"
        )
    return disc
