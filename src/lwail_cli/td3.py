"""TD3 (Fujimoto et al., 2018) with the hot path kept lean.

What is computed is textbook TD3 (``benchmarks/plain_td3.py`` is the straightforward reference, and
tests check one update of each gives the same parameters). What differs is how: the twin critics
are one stacked module (one batched matmul for both), the actor loss reads the critic through
detached weights (no wasted critic gradients), Adam is fused, the target updates are one foreach lerp per rate,
and nothing in an update asks the device for a Python number.
"""

from __future__ import annotations

import copy

import numpy as np
import torch
from torch import nn

from .config import TD3Config
from .envs import EnvInfo
from .nets import StackedMLP, mlp


class Actor(nn.Module):
    """Deterministic policy: tanh output scaled to the action bounds."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: tuple[int, ...], low, high):
        super().__init__()
        self.net = mlp(obs_dim, hidden, act_dim)
        low, high = torch.as_tensor(low, dtype=torch.float32), torch.as_tensor(high, dtype=torch.float32)
        self.register_buffer("scale", (high - low) / 2)
        self.register_buffer("offset", (high + low) / 2)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.net(obs)) * self.scale + self.offset

    @classmethod
    def for_env(cls, env: EnvInfo, hidden: tuple[int, ...]) -> Actor:
        return cls(env.obs_dim, env.act_dim, hidden, env.action_low, env.action_high)


def _adam(params, lr: float, device: torch.device) -> torch.optim.Adam:
    return torch.optim.Adam(params, lr=lr, fused=device.type in ("cpu", "cuda"))


class TD3:
    def __init__(self, env: EnvInfo, config: TD3Config, device: torch.device | str = "cpu", average_tau: float = 0.0):
        """``average_tau > 0`` also keeps a slower Polyak average of the actor, updated with the targets: a
        candidate policy to evaluate and keep. Nothing reads it in an update, so it leaves training unchanged."""
        self.config = config
        self.device = torch.device(device)
        self.actor = Actor.for_env(env, config.hidden).to(self.device)
        self.actor_target = Actor.for_env(env, config.hidden).to(self.device)
        self.actor_target.load_state_dict(self.actor.state_dict())
        self.average_tau = average_tau
        # a copy, not a new Actor: building one would draw from torch's generator and change every later initialisation
        self.actor_average = copy.deepcopy(self.actor).requires_grad_(False) if average_tau > 0 else None
        self._policies = {"actor": self.actor, "target": self.actor_target} | ({} if self.actor_average is None else {"average": self.actor_average})
        self.critic = StackedMLP(2, env.obs_dim + env.act_dim, config.hidden, 1).to(self.device)
        self.critic_target = StackedMLP(2, env.obs_dim + env.act_dim, config.hidden, 1).to(self.device)
        self.critic_target.load_state_dict(self.critic.state_dict())
        for target in (self.actor_target, self.critic_target):
            target.requires_grad_(False)
        self.actor_optimizer = _adam(self.actor.parameters(), config.actor_lr, self.device)
        self.critic_optimizer = _adam(self.critic.parameters(), config.critic_lr, self.device)
        scale = self.actor.scale
        self._noise_std = config.target_noise * scale
        self._noise_clip = config.target_noise_clip * scale
        self._low, self._high = self.actor.offset - scale, self.actor.offset + scale
        # the Polyak pairs, listed once: every network that follows at rate tau, and the slower average
        self._followers = [*self.critic_target.parameters(), *self.actor_target.parameters()]
        self._leaders = [*self.critic.parameters(), *self.actor.parameters()]
        self.updates = 0
        self.last_critic_loss = torch.zeros((), device=self.device)

    def networks(self) -> dict[str, Actor]:
        """The policies this agent holds: the online actor, its Polyak average (the target) and, when kept, the slower average."""
        return self._policies

    def network(self, which: str) -> Actor:
        return self._policies[which]

    @torch.inference_mode()
    def act(self, obs: np.ndarray, which: str = "actor") -> np.ndarray:
        """Deterministic action of ``network(which)`` for one observation or a batch of them."""
        tensor = torch.as_tensor(obs, dtype=torch.float32, device=self.device)
        return self.network(which)(tensor).cpu().numpy()

    @torch.inference_mode()
    def policy_values(self, obs: np.ndarray, which: str = "actor") -> torch.Tensor:
        """min over the twin critics of Q(s, π(s)) for each observation, π = ``network(which)``: what the critic
        expects the policy to earn from each state."""
        states = torch.as_tensor(obs, dtype=torch.float32, device=self.device)
        return self.critic(torch.cat([states, self.network(which)(states)], 1)).amin(0).squeeze(1)

    def update(self, batch: dict[str, torch.Tensor]) -> None:
        cfg = self.config
        obs, actions = batch["observations"], batch["actions"]
        next_obs = batch["next_observations"]
        with torch.no_grad():  # in-place where nothing else reads the tensor: the same values, fewer allocations
            noise = torch.randn_like(actions).mul_(self._noise_std).clamp_(-self._noise_clip, self._noise_clip)
            next_actions = self.actor_target(next_obs).add_(noise).clamp_(self._low, self._high)
            next_q = self.critic_target(torch.cat([next_obs, next_actions], 1)).amin(0)
            target = batch["rewards"] + cfg.gamma * batch["not_terminated"] * next_q
        q = self.critic(torch.cat([obs, actions], 1))
        critic_loss = self.critic_loss(obs, q, target)
        self.critic_optimizer.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_optimizer.step()
        self.last_critic_loss = critic_loss.detach()
        self.updates += 1
        if self.updates % cfg.policy_delay == 0:
            actor_loss = self.actor_loss(obs)
            self.actor_optimizer.zero_grad(set_to_none=True)
            actor_loss.backward()
            self.actor_optimizer.step()
            with torch.no_grad():  # θ' ← θ' + τ(θ − θ'): the textbook (1−τ)θ' + τθ to rounding, in one pass
                torch._foreach_lerp_(self._followers, self._leaders, cfg.tau)
                if self.actor_average is not None:
                    torch._foreach_lerp_(list(self.actor_average.parameters()), list(self.actor.parameters()), self.average_tau)

    def critic_loss(self, obs: torch.Tensor, q: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """The twin critics' loss given their values ``q`` of the batch's (s, a) and the TD ``target``: the sum of
        their mean squared errors (a method that changes TD3's objective overrides this and ``actor_loss``)."""
        return (q - target).square().mean(dim=(1, 2)).sum()

    def actor_loss(self, obs: torch.Tensor) -> torch.Tensor:
        """−Q₁(s, π(s)) over the batch, read through the critic's detached weights."""
        return -self.critic(torch.cat([obs, self.actor(obs)], 1), members=slice(0, 1), detach=True).mean()

    def state_dict(self) -> dict:
        return {
            "actor": self.actor.state_dict(),
            "actor_target": self.actor_target.state_dict(),
            "critic": self.critic.state_dict(),
            "critic_target": self.critic_target.state_dict(),
            "actor_optimizer": self.actor_optimizer.state_dict(),
            "critic_optimizer": self.critic_optimizer.state_dict(),
            "updates": self.updates,
        } | ({} if self.actor_average is None else {"actor_average": self.actor_average.state_dict()})

    def load_state_dict(self, state: dict) -> None:
        for name in ("actor", "actor_target", "critic", "critic_target", "actor_optimizer", "critic_optimizer"):
            getattr(self, name).load_state_dict(state[name])
        self.updates = int(state["updates"])
        if self.actor_average is not None:  # a checkpoint made without it starts the average at the target actor
            self.actor_average.load_state_dict(state.get("actor_average", state["actor_target"]))

