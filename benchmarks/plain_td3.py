"""Textbook TD3 in plain eager PyTorch: the baseline the fast path is measured and checked against.

Two separate critic networks, ``F.mse_loss`` per critic, a parameter loop for the target update,
default (non-fused) Adam. Same sizes and hyper-parameters as ``lwail_cli.td3.TD3``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from lwail_cli.config import TD3Config
from lwail_cli.envs import EnvInfo
from lwail_cli.nets import mlp
from lwail_cli.td3 import Actor


class PlainTD3:
    def __init__(self, env: EnvInfo, config: TD3Config):
        self.config = config
        self.actor = Actor.for_env(env, config.hidden)
        self.actor_target = Actor.for_env(env, config.hidden)
        self.actor_target.load_state_dict(self.actor.state_dict())
        self.critics = nn.ModuleList(mlp(env.obs_dim + env.act_dim, config.hidden, 1) for _ in range(2))
        self.critics_target = nn.ModuleList(mlp(env.obs_dim + env.act_dim, config.hidden, 1) for _ in range(2))
        self.critics_target.load_state_dict(self.critics.state_dict())
        self.actor_optimizer = torch.optim.Adam(self.actor.parameters(), lr=config.actor_lr)
        self.critic_optimizer = torch.optim.Adam(self.critics.parameters(), lr=config.critic_lr)
        self.updates = 0

    def load_from_stacked(self, agent) -> None:
        """Copy the weights of a ``lwail_cli.td3.TD3`` (stacked critics) into these separate ones."""
        self.actor.load_state_dict(agent.actor.state_dict())
        self.actor_target.load_state_dict(agent.actor_target.state_dict())
        for source, critics in ((agent.critic, self.critics), (agent.critic_target, self.critics_target)):
            for member, critic in enumerate(critics):
                linears = [layer for layer in critic if isinstance(layer, nn.Linear)]
                for linear, weight, bias in zip(linears, source.weights, source.biases):
                    linear.weight.data.copy_(weight[member].T)
                    linear.bias.data.copy_(bias[member, 0])

    def update(self, batch: dict[str, torch.Tensor]) -> None:
        cfg = self.config
        obs, actions, rewards = batch["observations"], batch["actions"], batch["rewards"]
        next_obs, not_done = batch["next_observations"], batch["not_terminated"]
        scale = self.actor.scale
        with torch.no_grad():
            noise = (torch.randn_like(actions) * cfg.target_noise * scale).clamp(-cfg.target_noise_clip * scale, cfg.target_noise_clip * scale)
            next_actions = (self.actor_target(next_obs) + noise).clamp(self.actor.offset - scale, self.actor.offset + scale)
            next_input = torch.cat([next_obs, next_actions], 1)
            next_q = torch.min(self.critics_target[0](next_input), self.critics_target[1](next_input))
            target = rewards + cfg.gamma * not_done * next_q
        current = torch.cat([obs, actions], 1)
        critic_loss = F.mse_loss(self.critics[0](current), target) + F.mse_loss(self.critics[1](current), target)
        self.critic_optimizer.zero_grad()
        critic_loss.backward()
        self.critic_optimizer.step()
        self.updates += 1
        if self.updates % cfg.policy_delay == 0:
            actor_loss = -self.critics[0](torch.cat([obs, self.actor(obs)], 1)).mean()
            self.actor_optimizer.zero_grad()
            actor_loss.backward()
            self.actor_optimizer.step()
            with torch.no_grad():
                for net, target_net in ((self.critics, self.critics_target), (self.actor, self.actor_target)):
                    for param, target_param in zip(net.parameters(), target_net.parameters()):
                        target_param.data.copy_(cfg.tau * param.data + (1 - cfg.tau) * target_param.data)
