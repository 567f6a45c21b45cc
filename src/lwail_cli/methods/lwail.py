"""LWAIL (Yang et al., "Latent Wasserstein Adversarial Imitation Learning"): the reward σ(−f) of the WGAN-GP critic f,
warmed up by `lwail warmup-disc` and trained online on the adversarial schedule of ``imitation.AdversarialReward``."""

from __future__ import annotations

from ..discriminator import DiscriminatorTrainer
from ..imitation import AdversarialReward
from .base import Inputs, Method, adversarial_reward


def build(inputs: Inputs) -> AdversarialReward:
    # f keeps the loss and learning rate it was warmed up with
    return adversarial_reward(inputs, DiscriminatorTrainer(inputs.critic, inputs.critic_config))


METHOD = Method("lwail", "LWAIL", "LWAIL pseudo-reward", reads_discriminator=True, caches_features=True, build=build, reward="σ(−f)")
