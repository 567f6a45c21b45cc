"""GAIfO (Torabi, Warnell & Stone 2018, "Generative Adversarial Imitation from Observation"), with DAC's gradient
penalty (Kostrikov et al. 2019, "Discriminator-Actor-Critic"; we follow google-research/dac/gail.py).

A discriminator D on the pair features ``x = [φ(s), φ(s') − φ(s)]`` (GAIfO's (s, s'), through the same φ as every
method) is trained with binary cross-entropy, expert pairs labelled 1 and the policy's latest pairs 0, plus
λ·(‖∇D(x̂)‖₂ − 1)² at expert-policy interpolates x̂ (the WGAN-GP term DAC adds). The reward is −log(1 − σ(D(x))),
DAC's "GAIL" reward, computed as softplus(D(x)) (the same value without 1 − σ rounding to 0) and capped at
``REWARD_CEILING``. D starts untrained (no warm-up artifact) and is trained, and the buffer relabelled, on LWAIL's
schedule (``imitation.AdversarialReward``: every ``update_every`` env steps, ``update_steps`` full-batch steps on
the latest window), so that the comparison differs only in the adversary.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..discriminator import Critic, DiscriminatorTrainer, gradient_penalty
from ..imitation import AdversarialReward
from ..learning_curve import DISCRIMINATOR_LOSS
from .base import Inputs, Method, adversarial_reward

REWARD_CEILING = 10.0  # −log(1 − D) at D = 1 − 4.5e-5: a saturated D cannot hand TD3 an unbounded reward


class GaifoTrainer(DiscriminatorTrainer):
    """D (a ``Critic`` network, never standardised, whose output is D's logit) and its Adam (``GaifoConfig.lr``), on
    the full-batch updates of LWAIL's trainer; ``last_wasserstein`` holds the last update's cross-entropy."""

    FILE = "discriminator.safetensors"
    ESTIMATE = DISCRIMINATOR_LOSS

    def loss(self, expert: torch.Tensor, policy: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Cross-entropy (expert 1, policy 0) plus the gradient penalty, and the cross-entropy alone."""
        logit_expert, logit_policy = self.critic(expert), self.critic(policy)
        entropy = (F.binary_cross_entropy_with_logits(logit_expert, torch.ones_like(logit_expert))
                   + F.binary_cross_entropy_with_logits(logit_policy, torch.zeros_like(logit_policy)))
        return entropy + self.config.gp_weight * gradient_penalty(self.critic, expert, policy), entropy.detach()

    @staticmethod
    def rewarded(scores: torch.Tensor) -> torch.Tensor:
        """−log(1 − σ(logit)), capped."""
        return F.softplus(scores).clamp(max=REWARD_CEILING)


def build(inputs: Inputs) -> AdversarialReward:
    discriminator = Critic(inputs.expert.shape[1], inputs.config.gaifo.hidden).to(inputs.expert.device)
    return adversarial_reward(inputs, GaifoTrainer(discriminator, inputs.config.gaifo))


METHOD = Method("gaifo", "GAIfO", "GAIfO reward −log(1 − D)", reads_discriminator=False, caches_features=True, build=build,
                reward="−log(1 − D)")
