"""The LWAIL imitation loop as the benchmarks and the profile build it: the real stage's parts at the real sizes.

φ has the ICVF defaults' shape and f the critic defaults' (their weights are fresh, which costs the same per step as
trained ones), the expert is 1,000 transitions of a random policy, and the schedule is the stage's: TD3's defaults,
f trained and the buffer relabelled every ``update_every`` steps, evaluations of every kept network.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from lwail_cli import config as cfg
from lwail_cli.discriminator import Critic, DiscriminatorTrainer, transition_features
from lwail_cli.envs import EnvInfo, describe_env
from lwail_cli.icvf import Encoder
from lwail_cli.imitation import AdversarialReward
from lwail_cli.replay import ReplayBuffer
from lwail_cli.rollout import rollout
from lwail_cli.td3 import TD3


@dataclass
class LwailParts:
    info: EnvInfo
    config: cfg.ImitationConfig
    agent: TD3
    buffer: ReplayBuffer
    reward: AdversarialReward


def build_lwail(env_id: str, *, warmup: int, steps: int, device: torch.device, eval_every: int | None = None,
                average_tau: float = 0.0, seed: int = 0) -> LwailParts:
    """Parts for ``warmup`` random-action steps (no update before them) then ``steps`` imitation steps; evaluations
    every ``eval_every`` steps (None: none before the last step)."""
    info = describe_env(env_id)
    total = warmup + steps
    config = cfg.ImitationConfig(
        td3=cfg.TD3Config(random_steps=warmup, learning_starts=warmup),
        train=cfg.TrainConfig(steps=total, eval_every=eval_every or 10 * total, checkpoint_every=10 * total, average_tau=average_tau),
    )
    torch.manual_seed(seed)
    encoder = Encoder(info.obs_dim, cfg.ICVFConfig()).to(device).requires_grad_(False)
    expert_episodes = rollout(env_id, None, [seed + 1], record=True, transitions=1000).episodes
    with torch.no_grad():
        states = torch.as_tensor(np.concatenate([e.observations[:-1] for e in expert_episodes]), device=device)
        successors = torch.as_tensor(np.concatenate([e.observations[1:] for e in expert_episodes]), device=device)
        expert = transition_features(encoder, states, successors)
    critic = cfg.CriticConfig()
    trainer = DiscriminatorTrainer(Critic(expert.shape[1], critic.hidden).to(device), critic)
    reward = AdversarialReward(encoder, trainer, expert, total, update_every=config.update_every, update_steps=config.update_steps)
    agent = TD3(info, config.td3, device, average_tau=average_tau)
    buffer = ReplayBuffer(total, info.obs_dim, info.act_dim, device)
    return LwailParts(info, config, agent, buffer, reward)
