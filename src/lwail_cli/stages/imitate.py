"""Stage: imitation — an imitation method of ``methods.METHODS`` on the same φ, demo, seeds and evaluation: TD3 on its
reward (LWAIL's σ(−f(φ(s), φ(s'))), f updated online from the warmed-up critic, or a baseline's), or its own loop (BCO)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd
import torch

from .. import config as cfg
from .. import learning_curve
from ..data import transition_pairs, transitions_with_actions
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..loaders import critic_config, load_critic, load_dataset, load_encoder, parent, save_weights
from ..methods import METHODS, Inputs, Method, Session, Trained, Transitions
from ..plots import plot_run
from ..runs import open_run, run_record
from .online import final_metrics, session, start_online_run, train_policy, write_curve
from .shared import Progress, default_name, expert_pairs, pair_features, reference_for_env

if TYPE_CHECKING:
    import numpy as np

    from ..artifacts import Artifact, Store
    from ..data import Episode

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
    # data set I: the random-policy pairs f was warmed up against (LWAIL), else those φ was trained on
    dataset = parent(store, disc or embedding, "dataset")
    episodes = load_dataset(dataset)
    random_states = tuple(pairs[:DIAGNOSTIC_PAIRS] for pairs in transition_pairs(episodes))
    transitions = _with_actions(method, dataset, episodes) if method.reads_actions else None
    reference = reference_for_env(env_id, demos)
    name = name or default_name(env_id, config.method)
    parents = [demos, embedding] + ([disc] if disc else [])
    critic_record = {"critic": cfg.to_dict(critic)} if critic else {}
    record = cfg.to_dict(config) | critic_record
    as_0_3 = cfg.recorded_by_0_3(config)  # a checkpoint lwail 0.3 wrote recorded every section, read or not
    with open_run(store, "policy", name, resume=resume, record=run_record(record, seed, env_id, parents), config_class=cfg.ImitationConfig,
                  recorded_by_0_3=None if as_0_3 is None else run_record(as_0_3 | critic_record, seed, env_id, parents)) as run:
        width = (disc.config["input_dim"] if disc else 2 * load_encoder(embedding).dim) if method.caches_features else 0
        capacity = start_online_run(run, info, config, seed, feature_width=width)  # then φ and the method's networks
        # (a warmed-up f's initial weights replaced by its artifact's) draw from torch's generator before the agent does
        encoder = load_encoder(embedding, device)
        inputs = Inputs(
            config=config, encoder=encoder, expert=pair_features(encoder, *expert_states, device),
            random=pair_features(encoder, *random_states, device), capacity=capacity,
            critic=load_critic(disc, device) if disc else None, critic_config=critic,
            expert_states=torch.as_tensor(expert_states[0], device=device),
            dataset=Transitions(*(torch.as_tensor(array, device=device) for array in transitions)) if transitions else None,
        )
        hooks = session(run, info=info, seed=seed, device=device, reference=reference, on_progress=on_progress)
        trained = method.train(inputs, hooks) if method.train is not None else _td3_on_reward(method, inputs, hooks)
        with store.create("policy", name, env=info, config=record, seed=seed, parents=parents, extra={"trained_on": method.trained_on}) as writer:
            write_curve(writer.path(learning_curve.FILE), trained.state)
            save_weights(writer.path("actor.safetensors"), trained.actor.state_dict())
            for filename, weights in trained.weights.items():
                save_weights(writer.path(filename), weights)
            plot_run(pd.DataFrame(trained.state.history), writer.path("learning_curve.png"), writer.path("pseudo_reward_vs_return.png"),
                     f"{method.label} on {env_id}", method.reward)
            writer.metrics.update(final_metrics(trained.state, reference))
    return writer.artifact


def _td3_on_reward(method: Method, inputs: Inputs, hooks: Session) -> Trained:
    """TD3 on the reward learner the method builds (after φ, so that it draws from torch's generator before the agent)."""
    reward_model = method.build(inputs)
    trained = train_policy(hooks, config=inputs.config, capacity=inputs.capacity, reward_model=reward_model)
    return Trained(trained.state, trained.agent.network(inputs.config.train.policy), reward_model.weights())


def _with_actions(method: Method, dataset: Artifact, episodes: list[Episode]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Data set I's (s, a, s'), refused in one line where it has no actions (an imported state-only data set)."""
    transitions = transitions_with_actions(episodes)
    if transitions is None:
        raise LwailError(f"--method {method.name} learns from data set I's actions, but {dataset.ref} has none (imported "
                         "state-only): give an --embedding trained on a data set from `lwail collect`")
    return transitions


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
