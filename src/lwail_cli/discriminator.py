"""The Kantorovich–Rubinstein critic f (the discriminator) and the pseudo-reward σ(−f).

f is trained to be low on expert transitions and high on the policy's:
loss = mean g(f(x_E)) − mean g(f(x_π)) + λ·mean(‖∇f(x̂)‖₂ − 1)², on x = [φ(s), φ(s') − φ(s)],
with g = tanh (the authors' code) or the identity (the paper's plain dual); see docs/algorithm.md.
With ``critic.standardize`` each input is first standardised by fixed statistics of data set I, and the gradient
penalty holds f's slope to 1 in those units, not in φ's own (whose scale ICVF does not control).
"""

from __future__ import annotations

from typing import Callable

import torch
from torch import nn

from .config import CriticConfig
from .learning_curve import WASSERSTEIN
from .nets import mlp


MIN_SCALE = 1e-6  # an input that never varies over data set I is centred, not blown up


class Critic(nn.Module):
    """f(x) = score(standardized(x)); ``standardized`` is the identity unless ``standardize`` (then a fixed shift and
    scale per input, set by ``fit_standardization`` and saved with the weights)."""

    def __init__(self, in_dim: int, hidden: tuple[int, ...], standardize: bool = False):
        super().__init__()
        self.net = mlp(in_dim, hidden, 1)
        self.standardize = standardize
        if standardize:
            self.register_buffer("shift", torch.zeros(in_dim))
            self.register_buffer("scale", torch.ones(in_dim))

    def standardized(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.shift) / self.scale if self.standardize else x

    def score(self, z: torch.Tensor) -> torch.Tensor:
        """f on inputs already standardised."""
        return self.net(z).squeeze(-1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.score(self.standardized(x))

    @torch.no_grad()
    def fit_standardization(self, features: torch.Tensor) -> None:
        """Shift and scale each input to zero mean and unit spread over ``features`` (data set I's pairs)."""
        self.shift.copy_(features.mean(dim=0))
        self.scale.copy_(features.std(dim=0).clamp_min(MIN_SCALE))


def transition_features(encode: nn.Module, states: torch.Tensor, next_states: torch.Tensor) -> torch.Tensor:
    """``[φ(s), φ(s') − φ(s)]``, the critic's input."""
    both = encode(torch.cat([states, next_states]))
    phi, phi_next = both.chunk(2)
    return torch.cat([phi, phi_next - phi], dim=-1)


def gradient_penalty(critic: Callable[[torch.Tensor], torch.Tensor], expert: torch.Tensor, policy: torch.Tensor) -> torch.Tensor:
    """WGAN-GP: mean (‖∇f(x̂)‖₂ − 1)² at per-sample interpolates of expert and policy inputs."""
    epsilon = torch.rand(expert.shape[0], 1, device=expert.device)
    mixed = (epsilon * expert + (1.0 - epsilon) * policy).requires_grad_(True)
    (gradient,) = torch.autograd.grad(critic(mixed).sum(), mixed, create_graph=True)
    return (gradient.norm(2, dim=-1) - 1.0).square().mean()


def critic_loss(critic: Critic, expert: torch.Tensor, policy: torch.Tensor, config: CriticConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """The loss to minimise and the critic's Wasserstein estimate ``E_π f − E_E f``."""
    expert, policy = critic.standardized(expert), critic.standardized(policy)
    f_expert, f_policy = critic.score(expert), critic.score(policy)
    if config.tanh:
        f_expert, f_policy = torch.tanh(f_expert), torch.tanh(f_policy)
    wasserstein = f_policy.mean() - f_expert.mean()
    return -wasserstein + config.gp_weight * gradient_penalty(critic.score, expert, policy), wasserstein.detach()


class DiscriminatorTrainer:
    """Full-batch critic updates: as many expert rows, drawn with replacement, as there are policy rows (LWAIL's
    adversary in ``imitation.AdversarialReward``)."""

    FILE = "critic.safetensors"  # where a policy artifact keeps the final f
    ESTIMATE = WASSERSTEIN  # what the loss measures beside itself (kept as last_wasserstein), as the learning curve names it

    def __init__(self, critic: Critic, config: CriticConfig):
        self.critic = critic
        self.config = config
        device = next(critic.parameters()).device
        self.optimizer = torch.optim.Adam(critic.parameters(), lr=config.lr, fused=device.type in ("cpu", "cuda"))
        self.last_wasserstein = torch.zeros((), device=device)

    def train(self, expert: torch.Tensor, policy: torch.Tensor, steps: int) -> torch.Tensor:
        """``steps`` updates; each draws expert rows (with replacement) to match the policy rows."""
        for _ in range(steps):
            index = torch.randint(0, expert.shape[0], (policy.shape[0],), device=expert.device)
            loss, self.last_wasserstein = self.loss(expert[index], policy)
            self.optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.optimizer.step()
        return self.last_wasserstein

    def loss(self, expert: torch.Tensor, policy: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The loss to minimise and its ``ESTIMATE``."""
        return critic_loss(self.critic, expert, policy, self.config)

    @torch.no_grad()
    def reward(self, features: torch.Tensor) -> torch.Tensor:
        return self.rewarded(self.critic(features))

    @staticmethod
    def rewarded(scores: torch.Tensor) -> torch.Tensor:
        """The pseudo-reward σ(−f) of critic outputs (differentiable)."""
        return torch.sigmoid(-scores)

    def estimate(self) -> dict[str, float]:
        """What the last update measured, as the learning curve names it."""
        return {self.ESTIMATE: float(self.last_wasserstein)}

    def state_dict(self) -> dict:
        return {"critic": self.critic.state_dict(), "optimizer": self.optimizer.state_dict(), "last_wasserstein": self.last_wasserstein}

    def load_state_dict(self, state: dict) -> None:
        self.critic.load_state_dict(state["critic"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.last_wasserstein = state["last_wasserstein"].to(self.last_wasserstein.device)
