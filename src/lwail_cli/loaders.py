"""Artifacts into models, arrays and tables: what the stages and the Python API (``api.py``) both load.

Weights are safetensors files (no code runs when they are read); a model is rebuilt from the config its artifact
records, and weights that do not fit that config are refused with one line.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import pandas as pd
import torch
from safetensors.torch import load_file, save_file

from . import config as cfg
from .data import Episode
from .formats.minari_hdf5 import read_minari_directory
from .formats.npz import read_npz
from .discriminator import Critic
from .embeddings import embedding
from .errors import LwailError
from .learning_curve import FILES as CURVE_FILES
from .nets import Encoder
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
    """φ of an embedding artifact, rebuilt by the entry of its recorded type (``embeddings.py``)."""
    entry = embedding(artifact.config["type"])
    encoder = entry.encoder(artifact.config)
    if entry.trained:
        load_weights(encoder, artifact, "phi.safetensors")
    return encoder.to(device).requires_grad_(False).eval()


def critic_config(disc: Artifact) -> cfg.CriticConfig:
    """The settings f was warmed up with: the ones every later update of f must use."""
    return cfg.from_dict(cfg.CriticConfig, disc.config["critic"])


def load_critic(artifact: Artifact, device: torch.device | str = "cpu") -> Critic:
    config = critic_config(artifact)
    critic = Critic(artifact.config["input_dim"], config.hidden, standardize=config.standardize)
    load_weights(critic, artifact, "critic.safetensors")
    return critic.to(device)


def parent(store: Store, artifact: Artifact, kind: str) -> Artifact:
    """The direct parent of ``kind`` an artifact was made from (refused if it changed since)."""
    found = store.resolve_parent(artifact, kind)
    if found is None:
        raise LwailError(f"{artifact.ref} records no {kind} parent")
    return found


def read_curve(store: Store, *, ref: str) -> tuple[pd.DataFrame, str]:
    """The curve of the run named ``ref`` while it runs (or after a kill), else of the policy artifact ``ref``;
    with a line saying which was read."""
    live = live_curve(store, ref)
    if live is not None:
        return read_curve_file(live), f"run {ref} in progress or killed (last checkpoint kept): {live}"
    policy = store.resolve(ref, "policy")
    curve, path = policy_curve(policy)
    return curve, f"{policy.ref}: {path}"


def curve_figure_path(store: Store, *, refs: list[str]) -> Path:
    """Where ``lwail curve`` draws the runs ``refs`` unless told: beside the first one's curve (in the run area while
    it runs or after a kill, else beside its policy artifact's data, outside its hash), so that no run's figure
    replaces another's; the other runs drawn beside it are named in the file's name."""
    others = "".join("+" + re.sub(r"[^A-Za-z0-9._-]", "_", ref) for ref in refs[1:])
    filename = f"curve{others}.png"
    if live_curve(store, refs[0]) is not None:
        return store.runs.run_log("policy", refs[0], filename)
    return store.resolve(refs[0], "policy").beside(filename)


def live_curve(store: Store, ref: str) -> Path | None:
    """The curve file of the run named ``ref`` while it runs or after a kill (None if there is no such run)."""
    for filename in CURVE_FILES:
        try:
            live = store.runs.run_log("policy", ref, filename)
        except LwailError:  # not a plain name (e.g. name@v2 or a path): an artifact ref
            return None
        if live.is_file():
            return live
    return None


def policy_curve(policy: Artifact) -> tuple[pd.DataFrame, Path]:
    """The learning curve a policy artifact holds, and its file."""
    for filename in CURVE_FILES:
        if policy.file(filename).is_file():
            return read_curve_file(policy.file(filename)), policy.file(filename)
    raise LwailError(f"{policy.ref} holds no learning curve")


def read_curve_file(path: Path) -> pd.DataFrame:
    try:
        curve = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise LwailError(f"cannot read the learning curve {path}: {exc}") from None
    if "step" not in curve or "return_mean" not in curve:
        raise LwailError(f"{path} is not a learning curve (no step / return_mean columns)")
    return curve


def normalized_evaluations(policy: Artifact) -> pd.DataFrame:
    """The rows of the policy's ``evals.csv`` that carry a normalized score, oldest first (none: empty)."""
    if not policy.file("evals.csv").is_file():
        return pd.DataFrame(columns=["episodes", "seed", "normalized_score"])
    evals = pd.read_csv(policy.file("evals.csv"))
    evals["normalized_score"] = pd.to_numeric(evals["normalized_score"], errors="coerce")
    return evals[evals["normalized_score"].notna()]
