"""Textbook TD3 in plain eager PyTorch: the baseline the fast path is measured and checked against.

Two separate critic networks, ``F.mse_loss`` per critic, a parameter loop for the target update,
default (non-fused) Adam. Same sizes and hyper-parameters as ``lwail_cli.td3.TD3``.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from lwail_cli.config import TD3Config
from lwail_cli.envs import EnvInfo, env_info, make_env
from lwail_cli.nets import mlp
from lwail_cli.td3 import Actor


class PlainTD3:
    def __init__(self, env: EnvInfo, config: TD3Config, device: torch.device | str = "cpu"):
        self.config = config
        self.actor = Actor.for_env(env, config.hidden).to(device)
        self.actor_target = Actor.for_env(env, config.hidden).to(device)
        self.actor_target.load_state_dict(self.actor.state_dict())
        self.critics = nn.ModuleList(mlp(env.obs_dim + env.act_dim, config.hidden, 1) for _ in range(2)).to(device)
        self.critics_target = nn.ModuleList(mlp(env.obs_dim + env.act_dim, config.hidden, 1) for _ in range(2)).to(device)
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


class PlainReplayBuffer:
    """Fujimoto-style numpy buffer: sampled with numpy, copied into new tensors (and to the device) every batch."""

    def __init__(self, capacity: int, obs_dim: int, act_dim: int, device: torch.device | str = "cpu"):
        self.capacity, self.ptr, self.size, self.device = capacity, 0, 0, device
        self.obs = np.zeros((capacity, obs_dim), np.float32)
        self.act = np.zeros((capacity, act_dim), np.float32)
        self.next_obs = np.zeros((capacity, obs_dim), np.float32)
        self.reward = np.zeros((capacity, 1), np.float32)
        self.not_done = np.zeros((capacity, 1), np.float32)

    def add(self, obs, act, reward, next_obs, terminated) -> None:
        i = self.ptr
        self.obs[i], self.act[i], self.reward[i], self.next_obs[i], self.not_done[i] = obs, act, reward, next_obs, 1.0 - terminated
        self.ptr, self.size = (i + 1) % self.capacity, min(self.size + 1, self.capacity)

    def sample(self, batch_size: int) -> dict[str, torch.Tensor]:
        i = np.random.randint(0, self.size, size=batch_size)
        return {
            "observations": torch.FloatTensor(self.obs[i]).to(self.device),
            "actions": torch.FloatTensor(self.act[i]).to(self.device),
            "next_observations": torch.FloatTensor(self.next_obs[i]).to(self.device),
            "rewards": torch.FloatTensor(self.reward[i]).to(self.device),
            "not_terminated": torch.FloatTensor(self.not_done[i]).to(self.device),
        }


def run_plain_td3(env_id: str, warmup: int, steps: int, config: TD3Config, seed: int = 0, device: torch.device | str = "cpu") -> tuple[float, float]:
    """(CPU seconds, wall seconds) per env step of the textbook loop over ``steps`` steps after ``warmup`` random steps."""
    import time

    env = make_env(env_id, seed=seed)
    info = env_info(env)
    torch.manual_seed(seed)
    agent = PlainTD3(info, config, device)
    buffer = PlainReplayBuffer(warmup + steps, info.obs_dim, info.act_dim, device)
    obs, _ = env.reset(seed=seed)
    scale = (env.action_space.high - env.action_space.low) / 2
    started = None
    for step in range(warmup + steps):
        if step == warmup:
            started = time.process_time(), time.perf_counter()
        if step < warmup:
            action = env.action_space.sample()
        else:
            with torch.no_grad():
                action = agent.actor(torch.FloatTensor(obs.reshape(1, -1)).to(device)).cpu().numpy()[0]
            action = (action + np.random.normal(0, config.exploration_noise * scale)).clip(env.action_space.low, env.action_space.high)
        next_obs, reward, terminated, truncated, _ = env.step(action)
        buffer.add(obs, action, reward, next_obs, float(terminated))
        obs = env.reset()[0] if terminated or truncated else next_obs
        if step >= warmup:
            agent.update(buffer.sample(config.batch_size))
    return (time.process_time() - started[0]) / steps, (time.perf_counter() - started[1]) / steps
