"""Use lwail's results from Python: ``from lwail_cli import load_policy``.

``load_policy(ref).predict(obs)`` follows Stable-Baselines3's ``predict``: numpy in (any float dtype, one
observation or a batch), ``(actions, None)`` out. The stages themselves are plain functions with keyword
arguments (``lwail_cli.stages.imitate.imitate(store, env_id=..., ...)``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from .artifacts import Store
from .stages.shared import load_policy as load_actor
from .stages.shared import policy_fn


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
