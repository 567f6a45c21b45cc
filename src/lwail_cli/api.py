"""Use lwail's results from Python: ``from lwail_cli import load_policy, load_embedding, load_reward, load_episodes``.

``load_policy(ref).predict(obs)`` follows Stable-Baselines3's ``predict``: numpy in (any float dtype, one
observation or a batch), ``(actions, None)`` out. ``load_embedding(ref)(obs)`` is φ, ``load_reward(ref)(obs,
next_obs)`` a discriminator's reward σ(−f(φ(s), φ(s'))), and ``load_episodes(ref)`` a data set's or demos'
arrays. The stages themselves are plain functions with keyword arguments
(``lwail_cli.stages.imitate.imitate(store, env_id=..., ...)``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from .artifacts import Store
from .discriminator import transition_features
from .formats.npz import episode_arrays
from .loaders import load_critic, load_dataset, load_demos, load_encoder, parent, policy_fn
from .loaders import load_policy as load_actor


class Policy:
    """A trained lwail policy (an expert or an imitator)."""

    def __init__(self, actor: torch.nn.Module, env_id: str, ref: str):
        self.env_id, self.ref = env_id, ref
        self._act = policy_fn(actor)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True) -> tuple[np.ndarray, None]:
        """The deterministic action for one observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``."""
        obs = np.asarray(observation, dtype=np.float32)
        actions = self._act(obs[None] if obs.ndim == 1 else obs)
        return (actions[0] if obs.ndim == 1 else actions), None

    def __repr__(self) -> str:
        return f"Policy({self.ref}, env={self.env_id})"


def load_policy(ref: str, store: str | Path | None = None, device: str = "cpu") -> Policy:
    """A policy artifact by name, ``name@vN``, ``policy/name@vN`` or path (store: ``LWAIL_STORE`` or ./artifacts)."""
    artifact = Store(store).resolve(ref, "policy")
    return Policy(load_actor(artifact, device), artifact.env.id, artifact.ref)


def _batch(observation) -> tuple[torch.Tensor, bool]:
    obs = torch.as_tensor(np.asarray(observation, dtype=np.float32))
    return (obs[None], True) if obs.ndim == 1 else (obs, False)


class Embedding:
    """φ of an embedding artifact (the identity for ``--kind identity``): observations to latent vectors."""

    def __init__(self, encoder: torch.nn.Module, ref: str):
        self.ref, self._encoder = ref, encoder

    @torch.inference_mode()
    def __call__(self, observation) -> np.ndarray:
        obs, single = _batch(observation)
        latent = self._encoder(obs).numpy()
        return latent[0] if single else latent


class Reward:
    """A discriminator's reward σ(−f(φ(s), φ(s'))) for transitions (one or a batch), with the φ it was warmed up on."""

    def __init__(self, encoder: torch.nn.Module, critic: torch.nn.Module, ref: str):
        self.ref, self._encoder, self._critic = ref, encoder, critic

    @torch.inference_mode()
    def __call__(self, observation, next_observation) -> np.ndarray:
        obs, single = _batch(observation)
        following, _ = _batch(next_observation)
        reward = torch.sigmoid(-self._critic(transition_features(self._encoder, obs, following))).reshape(-1).numpy()
        return reward[0] if single else reward


def load_embedding(ref: str, store: str | Path | None = None) -> Embedding:
    artifact = Store(store).resolve(ref, "embedding")
    return Embedding(load_encoder(artifact), artifact.ref)


def load_reward(ref: str, store: str | Path | None = None) -> Reward:
    """A discriminator artifact as a reward function (a warm-up's f, or the final f inside an LWAIL policy's lineage)."""
    opened = Store(store)
    disc = opened.resolve(ref, "discriminator")
    return Reward(load_encoder(parent(opened, disc, "embedding")), load_critic(disc).eval(), disc.ref)


def load_episodes(ref: str, store: str | Path | None = None) -> dict[str, np.ndarray]:
    """A dataset's or demos' episodes (``name[@vN]`` where one kind holds the name, ``kind/name[@vN]`` or a path) as
    the .npz arrays: observations (N, d), episode_ends and terminations (N,)."""
    artifact = Store(store).resolve_any(ref)
    if artifact.kind == "dataset":
        return episode_arrays(load_dataset(artifact))
    if artifact.kind == "demos":
        return episode_arrays(load_demos(artifact)[0])
    raise ValueError(f"{artifact.ref} is a {artifact.kind}, not a dataset or demos")
