"""Textbook ICVF: one module per ensemble member, every value computed on its own, default Adam.

The reference ``lwail_cli.icvf.ICVFLearner`` (stacked members, shared projections) is checked against.
"""

from __future__ import annotations

import torch
from torch import nn

from lwail_cli.config import ICVFConfig


def _mlp(in_dim: int, config: ICVFConfig) -> nn.Sequential:
    """Every layer activated (φ, ψ and T all end in a GELU), with ``icvf.layer_norm``'s LayerNorm placement."""
    layers: list[nn.Module] = []
    for fan_in, fan_out in zip((in_dim, *config.hidden), (*config.hidden, config.embedding_dim)):
        layers += {
            "none": [nn.Linear(fan_in, fan_out), nn.GELU()],  # the authors' PyTorch ICVF (NormalMLP)
            "after": [nn.Linear(fan_in, fan_out), nn.GELU(), nn.LayerNorm(fan_out)],  # the JAX ICVF's LayerNormMLP
            "before": [nn.Linear(fan_in, fan_out), nn.LayerNorm(fan_out), nn.GELU()],
        }[config.layer_norm]
    return nn.Sequential(*layers)


class MultilinearValue(nn.Module):
    def __init__(self, obs_dim: int, config: ICVFConfig):
        super().__init__()
        dim = config.embedding_dim
        self.phi, self.psi, self.intention = _mlp(obs_dim, config), _mlp(obs_dim, config), _mlp(dim, config)
        self.matrix_a, self.matrix_b = nn.Linear(dim, dim), nn.Linear(dim, dim)

    def forward(self, s, outcome, intention):
        t = self.intention(self.psi(intention))
        return (self.matrix_a(t * self.phi(s)) * self.matrix_b(t * self.psi(outcome))).sum(-1)


class PlainICVF:
    def __init__(self, obs_dim: int, config: ICVFConfig):
        self.config = config
        self.members = nn.ModuleList(MultilinearValue(obs_dim, config) for _ in range(config.ensemble))
        self.targets = nn.ModuleList(MultilinearValue(obs_dim, config) for _ in range(config.ensemble))
        self.targets.load_state_dict(self.members.state_dict())
        self.optimizer = torch.optim.Adam(self.members.parameters(), lr=config.lr)

    def load_from_stacked(self, learner) -> None:
        for source, members in ((learner.model, self.members), (learner.target, self.targets)):
            for index, member in enumerate(members):
                for stacked, plain in ((source.phi, member.phi), (source.psi, member.psi), (source.intention, member.intention)):
                    for layer, linear in enumerate(m for m in plain if isinstance(m, nn.Linear)):
                        linear.weight.data.copy_(stacked.weights[layer][index].T)
                        linear.bias.data.copy_(stacked.biases[layer][index, 0])
                    for layer, norm in enumerate(m for m in plain if isinstance(m, nn.LayerNorm)):
                        norm.weight.data.copy_(stacked.norm_weights[str(layer)][index, 0])
                        norm.bias.data.copy_(stacked.norm_biases[str(layer)][index, 0])
                for stacked, plain in ((source.matrix_a, member.matrix_a), (source.matrix_b, member.matrix_b)):
                    plain.weight.data.copy_(stacked.weights[0][index].T)
                    plain.bias.data.copy_(stacked.biases[0][index, 0])

    def update(self, batch: dict[str, torch.Tensor]) -> None:
        cfg = self.config
        s, next_s, outcome, intention = batch["s"], batch["next_s"], batch["outcome"], batch["intention"]
        with torch.no_grad():
            next_v_intention = torch.stack([t(next_s, intention, intention) for t in self.targets]).min(0).values
            q_intention = batch["intention_reward"] + cfg.gamma * batch["intention_mask"] * next_v_intention
            v_intention = torch.stack([t(s, intention, intention) for t in self.targets]).mean(0)
            weight = torch.where(q_intention - v_intention >= 0, cfg.expectile, 1 - cfg.expectile)
        loss = 0.0
        for member, target in zip(self.members, self.targets):
            with torch.no_grad():
                q_outcome = batch["outcome_reward"] + cfg.gamma * batch["outcome_mask"] * target(next_s, outcome, intention)
            loss = loss + (weight * (q_outcome - member(s, outcome, intention)) ** 2).mean()
        self.optimizer.zero_grad()
        loss.backward()
        self.optimizer.step()
        with torch.no_grad():
            for param, target_param in zip(self.members.parameters(), self.targets.parameters()):
                target_param.data.copy_(cfg.tau * param.data + (1 - cfg.tau) * target_param.data)
