"""Network building blocks shared by the embeddings, the discriminator and TD3, and the Polyak target update.

``StackedMLP`` holds ``members`` independent MLPs (TD3's twin critics, ICVF's ensemble) as stacked
weights so that all members run as one batched matmul instead of one small matmul each. Every trained embedding's
φ has one shape (``embedding_net``), so one ``Encoder`` serves them all downstream.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Callable, Protocol

import torch
import torch.nn.functional as F
from torch import nn

# ReLU in place: every activated tensor is a fresh matmul (plus bias) output nothing else reads, so overwriting it gives
# the same values and gradients and saves an allocation and a pass over memory per layer
ACTIVATIONS = {"relu": partial(F.relu, inplace=True), "gelu": F.gelu}


def soft_update(target: nn.Module, source: nn.Module, tau: float) -> None:
    """``target ← (1−τ)·target + τ·source`` as two foreach ops over every tensor."""
    target_params = list(target.parameters())
    torch._foreach_mul_(target_params, 1.0 - tau)
    torch._foreach_add_(target_params, list(source.parameters()), alpha=tau)


def mlp(in_dim: int, hidden: tuple[int, ...], out_dim: int, activate_final: bool = False,
        activation: Callable[[], nn.Module] = partial(nn.ReLU, inplace=True)) -> nn.Sequential:
    """Linear layers, each but the last (unless ``activate_final``) followed by a new ``activation()`` module: ReLU
    in place (on a fresh Linear output, as in ACTIVATIONS) unless another is given."""
    layers: list[nn.Module] = []
    dims = (in_dim, *hidden, out_dim)
    for index, (fan_in, fan_out) in enumerate(zip(dims[:-1], dims[1:])):
        layers.append(nn.Linear(fan_in, fan_out))
        if index < len(dims) - 2 or activate_final:
            layers.append(activation())
    return nn.Sequential(*layers)


class StackedMLP(nn.Module):
    """``members`` MLPs with identical shapes and independent weights.

    Input ``(B, in)`` (shared by every member) or ``(members, B, in)``; output ``(members, B, out)``.
    Initialisation matches ``nn.Linear`` member by member. ``layer_norm`` places a LayerNorm in each layer:
    ``"none"``; ``"after"`` the activation, on activated layers only (the JAX ICVF's ``LayerNormMLP``:
    Dense → GELU → LayerNorm); ``"before"`` it, on every layer (Linear → LayerNorm → activation).
    """

    def __init__(
        self,
        members: int,
        in_dim: int,
        hidden: tuple[int, ...],
        out_dim: int,
        activation: str = "relu",
        activate_final: bool = False,
        layer_norm: str = "none",
    ):
        super().__init__()
        self.members = members
        self.activation = activation
        self.activate_final = activate_final
        self.layer_norm = layer_norm
        dims = (in_dim, *hidden, out_dim)
        self.depth = len(dims) - 1
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        # keyed by layer index: "after" leaves an unactivated last layer without one (state keys as a list's when all have one)
        self.norm_weights = nn.ParameterDict()
        self.norm_biases = nn.ParameterDict()
        for index, (fan_in, fan_out) in enumerate(zip(dims[:-1], dims[1:])):
            bound = 1.0 / math.sqrt(fan_in)
            self.weights.append(nn.Parameter(torch.empty(members, fan_in, fan_out).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(members, 1, fan_out).uniform_(-bound, bound)))
            if self._normalised(index):
                self.norm_weights[str(index)] = nn.Parameter(torch.ones(members, 1, fan_out))
                self.norm_biases[str(index)] = nn.Parameter(torch.zeros(members, 1, fan_out))

    def _activated(self, index: int) -> bool:
        return index < self.depth - 1 or self.activate_final

    def _normalised(self, index: int) -> bool:
        return self.layer_norm == "before" or self.layer_norm == "after" and self._activated(index)

    def forward(self, x: torch.Tensor, members: slice = slice(None), detach: bool = False) -> torch.Tensor:
        """Run the selected members; ``detach`` blocks gradients into the weights (not the input)."""
        activate = ACTIVATIONS[self.activation]
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            weight, bias = weight[members], bias[members]
            if detach:
                weight, bias = weight.detach(), bias.detach()
            if x.dim() == 2:  # shared input: every member reads the same rows, a broadcast view (no copy)
                x = x.expand(weight.shape[0], *x.shape)
            x = torch.baddbmm(bias, x, weight)  # bias, matmul and all members in one op (the wide matmul, its
            # transpose and the bias add it replaces cost ~1.5x as much, backward included)
            if self.layer_norm == "before":
                x = self._norm(x, index, members, detach)
            if self._activated(index):
                x = activate(x)
                if self.layer_norm == "after":
                    x = self._norm(x, index, members, detach)
        return x

    def _norm(self, x: torch.Tensor, index: int, members: slice, detach: bool) -> torch.Tensor:
        gain, shift = self.norm_weights[str(index)][members], self.norm_biases[str(index)][members]
        if detach:
            gain, shift = gain.detach(), shift.detach()
        return F.layer_norm(x, x.shape[-1:]) * gain + shift


class EmbeddingShape(Protocol):
    """The settings that shape φ (every trained embedding's config has them)."""

    hidden: tuple[int, ...]
    embedding_dim: int
    layer_norm: str


def embedding_net(members: int, in_dim: int, shape: EmbeddingShape) -> StackedMLP:
    """φ (and ICVF's ψ and T): GELU layers, the last one activated too, LayerNorm where ``shape.layer_norm`` says."""
    return StackedMLP(members, in_dim, shape.hidden, shape.embedding_dim, activation="gelu", activate_final=True, layer_norm=shape.layer_norm)


class Encoder(nn.Module):
    """The frozen φ used downstream: one trained ``embedding_net``, or the identity (``shape`` None)."""

    def __init__(self, obs_dim: int, shape: EmbeddingShape | None):
        super().__init__()
        self.net = embedding_net(1, obs_dim, shape) if shape is not None else None
        self.dim = shape.embedding_dim if shape is not None else obs_dim

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return obs if self.net is None else self.net(obs)[0]


def export_encoder(phi: StackedMLP, obs_dim: int, shape: EmbeddingShape) -> Encoder:
    """A frozen copy of member 0 of a trained φ."""
    with torch.random.fork_rng(devices=[]):  # its throw-away initialization must not shift training's random stream
        encoder = Encoder(obs_dim, shape)
    member_zero = {name: tensor[0:1].detach().clone() for name, tensor in phi.state_dict().items()}
    encoder.net.load_state_dict(member_zero)
    return encoder.requires_grad_(False).eval()
