"""Network building blocks shared by ICVF, the discriminator and TD3, and the Polyak target update.

``StackedMLP`` holds ``members`` independent MLPs (TD3's twin critics, ICVF's ensemble) as stacked
weights so that all members run as one batched matmul instead of one small matmul each.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

ACTIVATIONS = {"relu": F.relu, "gelu": F.gelu}


def soft_update(target: nn.Module, source: nn.Module, tau: float) -> None:
    """``target ← (1−τ)·target + τ·source`` as two foreach ops over every tensor."""
    target_params = list(target.parameters())
    torch._foreach_mul_(target_params, 1.0 - tau)
    torch._foreach_add_(target_params, list(source.parameters()), alpha=tau)


def mlp(in_dim: int, hidden: tuple[int, ...], out_dim: int, activate_final: bool = False) -> nn.Sequential:
    layers: list[nn.Module] = []
    dims = (in_dim, *hidden, out_dim)
    for index, (fan_in, fan_out) in enumerate(zip(dims[:-1], dims[1:])):
        layers.append(nn.Linear(fan_in, fan_out))
        if index < len(dims) - 2 or activate_final:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class StackedMLP(nn.Module):
    """``members`` MLPs with identical shapes and independent weights.

    Input ``(B, in)`` (shared by every member) or ``(members, B, in)``; output ``(members, B, out)``.
    Initialisation matches ``nn.Linear`` member by member. Layer norm, when on, is applied after
    each linear layer before the activation (as in the ICVF code's ``LayerNormMLP``).
    """

    def __init__(
        self,
        members: int,
        in_dim: int,
        hidden: tuple[int, ...],
        out_dim: int,
        activation: str = "relu",
        activate_final: bool = False,
        layer_norm: bool = False,
    ):
        super().__init__()
        self.members = members
        self.activation = activation
        self.activate_final = activate_final
        self.layer_norm = layer_norm
        dims = (in_dim, *hidden, out_dim)
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        self.norm_weights = nn.ParameterList()
        self.norm_biases = nn.ParameterList()
        for fan_in, fan_out in zip(dims[:-1], dims[1:]):
            bound = 1.0 / math.sqrt(fan_in)
            self.weights.append(nn.Parameter(torch.empty(members, fan_in, fan_out).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(members, 1, fan_out).uniform_(-bound, bound)))
            if layer_norm:
                self.norm_weights.append(nn.Parameter(torch.ones(members, 1, fan_out)))
                self.norm_biases.append(nn.Parameter(torch.zeros(members, 1, fan_out)))

    def forward(self, x: torch.Tensor, members: slice = slice(None), detach: bool = False) -> torch.Tensor:
        """Run the selected members; ``detach`` blocks gradients into the weights (not the input)."""
        activate = ACTIVATIONS[self.activation]
        last = len(self.weights) - 1
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            weight, bias = weight[members], bias[members]
            if detach:
                weight, bias = weight.detach(), bias.detach()
            if x.dim() == 2:  # shared input: one wide matmul for all members
                count, fan_in, fan_out = weight.shape
                wide = weight.permute(1, 0, 2).reshape(fan_in, count * fan_out)
                x = (x @ wide).view(x.shape[0], count, fan_out).transpose(0, 1) + bias
            else:
                x = torch.baddbmm(bias, x, weight)
            if self.layer_norm:
                gain, shift = self.norm_weights[index][members], self.norm_biases[index][members]
                if detach:
                    gain, shift = gain.detach(), shift.detach()
                x = F.layer_norm(x, x.shape[-1:]) * gain + shift
            if index < last or self.activate_final:
                x = activate(x)
        return x

    def member_state(self, member: int) -> dict[str, torch.Tensor]:
        """One member's weights as a flat dict (for exporting a single network)."""
        state = {}
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            state[f"{index}.weight"] = weight[member].detach().clone()
            state[f"{index}.bias"] = bias[member, 0].detach().clone()
            if self.layer_norm:
                state[f"{index}.norm_weight"] = self.norm_weights[index][member, 0].detach().clone()
                state[f"{index}.norm_bias"] = self.norm_biases[index][member, 0].detach().clone()
        return state
