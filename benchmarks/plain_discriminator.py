"""Textbook WGAN-GP critic step (default Adam, written out in full), the reference for
``lwail_cli.discriminator.DiscriminatorTrainer``."""

from __future__ import annotations

import torch
from torch import nn


def plain_critic_step(
    critic: nn.Module, optimizer: torch.optim.Optimizer, expert: torch.Tensor, policy: torch.Tensor, gp_weight: float, tanh: bool
) -> None:
    epsilon = torch.rand(expert.size(0), 1)
    interpolates = epsilon * expert + (1 - epsilon) * policy
    interpolates.requires_grad_(True)
    gradients = torch.autograd.grad(outputs=critic(interpolates).sum(), inputs=interpolates, create_graph=True)[0]
    penalty = ((gradients.norm(2, dim=1) - 1) ** 2).mean()
    squash = torch.tanh if tanh else (lambda f: f)  # the authors' code squashes f in the loss only
    loss = squash(critic(expert)).mean() - squash(critic(policy)).mean() + gp_weight * penalty
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
