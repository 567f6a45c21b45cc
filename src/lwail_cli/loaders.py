"""Artifacts into models and arrays: what the stages and the Python API (``api.py``) both load.

Weights are safetensors files (no code runs when they are read); a model is rebuilt from the config its artifact
records, and weights that do not fit that config are refused with one line.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import torch
from safetensors.torch import load_file, save_file

from . import config as cfg
from .data import Episode
from .formats.minari_hdf5 import read_minari_directory
from .formats.npz import read_npz
from .discriminator import Critic
from .errors import LwailError
from .icvf import Encoder
from .td3 import Actor

if TYPE_CHECKING:
    from .artifacts import Artifact, Store


def save_weights(path: Path, weights: dict[str, torch.Tensor]) -> None:
    save_file({k: v.detach().cpu().contiguous() for k, v in weights.items()}, str(path))


def load_weights(module: torch.nn.Module, artifact: Artifact, filename: str) -> None:
    try:
        module.load_state_dict(load_file(str(artifact.file(filename))))
    except (RuntimeError, KeyError) as exc:
        raise LwailError(f"{artifact.ref} holds weights in {filename} that do not fit its recorded config: {exc}") from None


def load_dataset(artifact: Artifact) -> list[Episode]:
    return read_minari_directory(artifact.file("minari"), artifact.ref)[0]


def load_demos(artifact: Artifact) -> tuple[list[Episode], np.ndarray]:
    return read_npz(artifact.file("demos.npz"))


def load_policy(artifact: Artifact, device: torch.device | str = "cpu") -> Actor:
    actor = Actor.for_env(artifact.env, tuple(artifact.config["td3"]["hidden"]))
    load_weights(actor, artifact, "actor.safetensors")
    return actor.to(device).eval()


def policy_fn(actor: Actor) -> Callable[[np.ndarray], np.ndarray]:
    """The actor as a numpy policy: a batch of observations (any float dtype) to a batch of actions."""
    device = next(actor.parameters()).device

    @torch.inference_mode()
    def act(obs: np.ndarray) -> np.ndarray:
        return actor(torch.as_tensor(obs, dtype=torch.float32, device=device)).cpu().numpy()

    return act


def load_encoder(artifact: Artifact, device: torch.device | str = "cpu") -> Encoder:
    record = artifact.config
    icvf_config = cfg.from_dict(cfg.ICVFConfig, record["icvf"]) if record["type"] == "icvf" else None
    encoder = Encoder(record["obs_dim"], icvf_config)
    if icvf_config is not None:
        load_weights(encoder, artifact, "phi.safetensors")
    return encoder.to(device).requires_grad_(False).eval()


def critic_config(disc: Artifact) -> cfg.CriticConfig:
    """The settings f was warmed up with: the ones every later update of f must use."""
    return cfg.from_dict(cfg.CriticConfig, disc.config["critic"])


def load_critic(artifact: Artifact, device: torch.device | str = "cpu") -> Critic:
    critic = Critic(artifact.config["input_dim"], critic_config(artifact).hidden)
    load_weights(critic, artifact, "critic.safetensors")
    return critic.to(device)


def parent(store: Store, artifact: Artifact, kind: str) -> Artifact:
    """The direct parent of ``kind`` an artifact was made from (refused if it changed since)."""
    found = store.resolve_parent(artifact, kind)
    if found is None:
        raise LwailError(f"{artifact.ref} records no {kind} parent")
    return found
