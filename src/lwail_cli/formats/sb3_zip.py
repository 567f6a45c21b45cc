"""Stable-Baselines3 interop: play an SB3 ``model.zip`` without unpickling it, and write an lwail actor as one.

``stable_baselines3.*.load`` unpickles parts of the zip (cloudpickle), so a shared model could run code. Here the
zip is read as data only: the readable JSON in ``data`` (policy module, ``net_arch``, activation, spaces) and the
weights in ``policy.pth`` (``torch.load(weights_only=True)``). Supported: TD3 and DDPG (tanh actor), SAC (the
mean action, squashed), PPO and A2C (the mean action, clipped), with flat Box spaces and MLP policies. Observation
normalisation (VecNormalize) lives outside the zip and is not applied.
"""

from __future__ import annotations

import io
import json
import pickle
import re
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from torch import nn

from ..envs import EnvInfo
from ..errors import LwailError

ACTIVATIONS = {"ReLU": nn.ReLU, "Tanh": nn.Tanh, "ELU": nn.ELU, "LeakyReLU": nn.LeakyReLU, "SiLU": nn.SiLU, "GELU": nn.GELU}
# (policy module, actor weight prefix, head prefix, default activation, how the head's output becomes an action)
FAMILIES = {
    "stable_baselines3.td3.policies": ("actor.mu.", None, "ReLU", "tanh"),
    "stable_baselines3.sac.policies": ("actor.latent_pi.", "actor.mu.", "ReLU", "tanh"),
    "stable_baselines3.common.policies": ("mlp_extractor.policy_net.", "action_net.", "Tanh", "clip"),
}


def read_sb3_policy(path: Path, env: EnvInfo) -> Callable[[np.ndarray], np.ndarray]:
    """The deterministic policy of an SB3 model.zip as a numpy function (a batch of observations to actions)."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
            weights = torch.load(io.BytesIO(archive.read("policy.pth")), map_location="cpu", weights_only=True)
    except (OSError, KeyError, ValueError, zipfile.BadZipFile, RuntimeError, pickle.UnpicklingError) as exc:
        raise LwailError(f"{path} is not a Stable-Baselines3 model.zip ({type(exc).__name__}: {exc})") from None
    module = data.get("policy_class", {}).get("__module__") if isinstance(data.get("policy_class"), dict) else None
    if module not in FAMILIES:
        raise LwailError(f"{path}: policy {module or 'unknown'} is not supported (TD3, DDPG, SAC, PPO and A2C MLP policies are)")
    body, head, default_activation, squash = FAMILIES[module]
    obs_shape = _shape(data.get("observation_space"))
    if obs_shape != [env.obs_dim]:
        raise LwailError(f"{path} was trained on observations of shape {obs_shape}, but {env.id} observations have {env.obs_dim} dims")
    activation = ACTIVATIONS[_activation(data.get("policy_kwargs"), default_activation)]
    layers = _linear_layers(weights, body)
    if head is not None:
        layers += _linear_layers(weights, head)
    network = nn.Sequential()
    for index, layer in enumerate(layers):
        network.append(layer)
        if index < len(layers) - 1:
            network.append(activation())
    if layers[-1].out_features != env.act_dim:
        raise LwailError(f"{path} outputs {layers[-1].out_features}-dim actions, but {env.id} has {env.act_dim}")
    low, high = np.asarray(env.action_low, dtype=np.float32), np.asarray(env.action_high, dtype=np.float32)
    network.eval()

    @torch.inference_mode()
    def act(obs: np.ndarray) -> np.ndarray:
        out = network(torch.as_tensor(np.asarray(obs, dtype=np.float32))).numpy()
        if squash == "tanh":
            return low + 0.5 * (np.tanh(out) + 1.0) * (high - low)
        return np.clip(out, low, high)

    return act


def _linear_layers(weights: dict, prefix: str) -> list[nn.Linear]:
    """The Linear layers stored under ``prefix`` (``prefix`` + index + .weight/.bias), in order."""
    found = {}
    for key, value in weights.items():
        match = re.fullmatch(re.escape(prefix) + r"(?:(\d+)\.)?(weight|bias)", key)
        if match:
            found.setdefault(int(match[1] or 0), {})[match[2]] = value
    if not found or any(set(pair) != {"weight", "bias"} or pair["weight"].ndim != 2 for pair in found.values()):
        raise LwailError(f"the model's weights have no MLP under {prefix!r} (only MLP policies are supported)")
    layers = []
    for index in sorted(found):
        weight, bias = found[index]["weight"], found[index]["bias"]
        layer = nn.Linear(weight.shape[1], weight.shape[0])
        layer.load_state_dict({"weight": weight.float(), "bias": bias.float()})
        layers.append(layer)
    for before, after in zip(layers, layers[1:]):
        if before.out_features != after.in_features:
            raise LwailError(f"the model's layers under {prefix!r} do not chain ({before.out_features} -> {after.in_features})")
    return layers


def _shape(space) -> list | None:
    try:
        shape = space["_shape"]
        return list(json.loads(shape) if isinstance(shape, str) else shape)
    except (TypeError, KeyError, ValueError):
        return None


def _activation(policy_kwargs, default: str) -> str:
    """The activation named in the readable part of policy_kwargs (e.g. "<class 'torch.nn...Tanh'>"), else the default."""
    text = str(policy_kwargs.get("activation_fn", "")) if isinstance(policy_kwargs, dict) else ""
    named = [name for name in ACTIVATIONS if re.search(rf"\.{name}'", text)]
    if text and not named:
        raise LwailError(f"the model's activation {text} is not supported ({', '.join(ACTIVATIONS)} are)")
    return named[0] if named else default


def write_sb3_td3(actor_weights: dict[str, torch.Tensor], hidden: tuple[int, ...], env_id: str, path: Path) -> None:
    """An SB3 TD3 model.zip whose actor is lwail's (same net_arch, ReLU, tanh scaled to the bounds); its critic is
    freshly initialised, since lwail policies keep only the actor."""
    try:
        import gymnasium as gym
        from stable_baselines3 import TD3
    except ImportError:
        raise LwailError('exporting to SB3 needs stable-baselines3: pip install "lwail[sb3]"') from None
    model = TD3("MlpPolicy", gym.make(env_id), policy_kwargs={"net_arch": list(hidden)}, device="cpu")
    indices = sorted({int(key.split(".")[1]) for key in actor_weights if key.startswith("net.")})
    for target in (model.actor.mu, model.actor_target.mu):
        linears = [layer for layer in target if isinstance(layer, nn.Linear)]
        if len(linears) != len(indices):
            raise LwailError(f"the policy's actor has {len(indices)} layers; SB3's has {len(linears)}")
        for layer, index in zip(linears, indices):
            layer.load_state_dict({"weight": actor_weights[f"net.{index}.weight"], "bias": actor_weights[f"net.{index}.bias"]})
    model.save(path)
