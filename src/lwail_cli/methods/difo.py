"""DIFO (Huang et al. 2024, "Diffusion Imitation from Observation", NeurIPS; arXiv:2410.05429), in the same harness. We follow
NTURobotLearningLab/DIFO: ``difo/difo/difo.py`` (the losses and the logit), ``difo/difo/diffusion_nets/base.py`` (the
noising, one draw per label), ``diffusion_nets/unet_1d_condition_reward_net.py`` and ``unet/unet1d.py`` (the network),
with the settings of its Walker2d run (``exp_configs/walker/difo.yaml`` over ``scripts/config/tuned_hps/algo/difo.yaml``
and ``reward_net/1d_condition_diffusion_reward.yaml``).

D is a conditional diffusion model of the next state given the state: ε_θ(y_t, t, x, c) predicts the noise ε in
y_t = √ᾱ_t·y + √(1 − ᾱ_t)·ε, for y = φ(s′), x = φ(s) (both scaled to [−1, 1] by the range of data set I's pairs and the
demo's) and a label c, 1 for the expert and 0 for the agent. Its denoising error under each label, L_c = the mean over
y's dimensions of (ε_θ − ε)² with a draw of ε and t of its own, gives D's logit κ·(L_0 − L_1): a pair the
expert-labelled model denoises better than the agent-labelled one is the expert's. D's loss is bce_weight × the
cross-entropy of that logit (expert 1, policy 0) plus the batch mean of L_1 on expert rows (0 on the policy's: the
reference's mse weights), with t ~ U{0, …, T−1}; the reward is −log(1 − σ(logit)) = softplus(logit) with
t ~ U{reward_t_low, …, reward_t_high − 1} (the reference's sampling at reward time), one draw, so it is noisy. D is
trained, and the buffer relabelled, on LWAIL's schedule (``imitation.AdversarialReward``), as GAIfO's D.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from ..config import DifoConfig
from ..discriminator import MIN_SCALE, DiscriminatorTrainer
from ..imitation import AdversarialReward
from ..learning_curve import DISCRIMINATOR_LOSS
from ..nets import mlp
from .base import Inputs, Method, adversarial_reward

EXPERT, AGENT = 1, 0  # the denoiser's class labels


def cosine_alpha_bars(steps: int) -> torch.Tensor:
    """ᾱ_t for t = 0 … T−1 of the cosine schedule (Nichol & Dhariwal 2021; diffusers' ``squaredcos_cap_v2``, which
    the reference uses): β_t = min(1 − ᾱ(t+1)/ᾱ(t), 0.999) with ᾱ(u) = cos²((u/T + 0.008)/1.008 · π/2), ᾱ_t = Π (1 − β)."""
    def alpha_bar(u: float) -> float:
        return math.cos((u / steps + 0.008) / 1.008 * math.pi / 2) ** 2

    betas = torch.tensor([min(1.0 - alpha_bar(t + 1) / alpha_bar(t), 0.999) for t in range(steps)], dtype=torch.float64)
    return torch.cumprod(1.0 - betas, dim=0).float()


def sinusoidal(times: torch.Tensor, width: int) -> torch.Tensor:
    """The transformer's position code of each step t, ``width`` wide (the reference's ``SinusoidalPosEmb``)."""
    half = width // 2
    frequencies = torch.exp(torch.arange(half, device=times.device) * -(math.log(10_000.0) / (half - 1)))
    angles = times.float()[:, None] * frequencies[None]
    return torch.cat([angles.sin(), angles.cos()], dim=-1)


class FilmBlock(nn.Module):
    """Linear → ReLU → Linear, scaled and shifted by the embedding, then ReLU (the reference's ``ResidualBlock``)."""

    def __init__(self, in_dim: int, out_dim: int, embedding: int):
        super().__init__()
        self.block = mlp(in_dim, (out_dim,), out_dim)
        self.film = mlp(embedding, (embedding,), 2 * out_dim)

    def forward(self, x: torch.Tensor, embedding: torch.Tensor) -> torch.Tensor:
        shift, scale = self.film(embedding).chunk(2, dim=-1)
        return F.relu(self.block(x) * scale + shift)


class Denoiser(nn.Module):
    """ε_θ(y_t, t, x, c): an input layer, FiLM blocks down the widths and back up with skip connections, an output
    layer; every block reads the sum of the embeddings of t, of the label c and of the state x (the reference's
    ``UNet1DModel`` with its condition MLP)."""

    def __init__(self, dim: int, hidden: tuple[int, ...], embedding: int):
        super().__init__()
        self.embedding = embedding
        self.labels = nn.Embedding(2, embedding)
        self.condition = mlp(dim, (embedding,), embedding)
        self.first = nn.Linear(dim, hidden[0])
        self.down = nn.ModuleList(FilmBlock(a, b, embedding) for a, b in zip(hidden[:-1], hidden[1:]))
        self.middle = mlp(hidden[-1], (max(hidden[-1] // 2, 1),), hidden[-1])
        widths = hidden[::-1]
        self.up = nn.ModuleList(FilmBlock(2 * a, b, embedding) for a, b in zip(widths[:-1], widths[1:]))
        self.last = nn.Linear(hidden[0], dim)

    def forward(self, noisy: torch.Tensor, times: torch.Tensor, labels: torch.Tensor, states: torch.Tensor) -> torch.Tensor:
        embedding = sinusoidal(times, self.embedding) + self.labels(labels) + self.condition(states)
        h, skips = self.first(noisy), []
        for block in self.down:
            h = block(h, embedding)
            skips.append(h)
        h = self.middle(h)
        for block, skip in zip(self.up, reversed(skips)):
            h = block(torch.cat([h, skip], dim=-1), embedding)
        return self.last(h)


class DiffusionDiscriminator(nn.Module):
    """D on the pair features ``[φ(s), φ(s′) − φ(s)]``: ``forward`` is its logit at reward time, ``errors`` the
    denoising errors under both labels; ``low``/``high`` (fitted by ``fit_range``, saved with the weights) scale φ to [−1, 1]."""

    def __init__(self, pair_dim: int, config: DifoConfig):
        super().__init__()
        dim = pair_dim // 2
        self.denoiser = Denoiser(dim, config.hidden, config.embedding)
        self.register_buffer("low", -torch.ones(dim))
        self.register_buffer("high", torch.ones(dim))
        self.register_buffer("alpha_bars", cosine_alpha_bars(config.diffusion_steps), persistent=False)
        self.logit_scale = config.logit_scale
        self.reward_times = (config.reward_t_low, config.reward_t_high)

    @torch.no_grad()
    def fit_range(self, features: torch.Tensor) -> None:
        """Each dimension's min and max over the φ(s) and φ(s′) of ``features`` (the reference's ``MinMaxNorm``, fixed here)."""
        phi, step = features.chunk(2, dim=-1)
        values = torch.cat([phi, phi + step])
        self.low.copy_(values.min(dim=0).values)
        self.high.copy_(torch.maximum(values.max(dim=0).values, self.low + MIN_SCALE))

    def scaled(self, phi: torch.Tensor) -> torch.Tensor:
        return 2.0 * (phi - self.low) / (self.high - self.low) - 1.0

    def errors(self, features: torch.Tensor, first_time: int, end_time: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Each pair's denoising error under the agent's label and under the expert's, t ~ U{first_time, …, end_time − 1},
        each label with its own draw (both labels run as one batch)."""
        phi, step = features.chunk(2, dim=-1)
        states, targets = self.scaled(phi).repeat(2, 1), self.scaled(phi + step).repeat(2, 1)
        rows = phi.shape[0]
        labels = torch.full((2 * rows,), AGENT, device=phi.device)
        labels[rows:] = EXPERT
        noise = torch.randn_like(targets)
        times = torch.randint(first_time, end_time, (2 * rows,), device=phi.device)
        alpha_bar = self.alpha_bars[times][:, None]
        noisy = alpha_bar.sqrt() * targets + (1.0 - alpha_bar).sqrt() * noise
        error = (self.denoiser(noisy, times, labels, states) - noise).square().mean(dim=-1)
        return error[:rows], error[rows:]

    def logit(self, agent_error: torch.Tensor, expert_error: torch.Tensor) -> torch.Tensor:
        return self.logit_scale * (agent_error - expert_error)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.logit(*self.errors(features, *self.reward_times))


class DifoTrainer(DiscriminatorTrainer):
    """D and its Adam (``DifoConfig.lr``) on the full-batch updates of LWAIL's trainer; ``last_wasserstein`` holds the
    last update's cross-entropy."""

    FILE = "discriminator.safetensors"
    ESTIMATE = DISCRIMINATOR_LOSS

    def loss(self, expert: torch.Tensor, policy: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """bce_weight × cross-entropy (expert 1, policy 0) + the expert-labelled denoising loss on expert rows, and
        the cross-entropy alone."""
        discriminator: DiffusionDiscriminator = self.critic
        agent_error, expert_error = discriminator.errors(torch.cat([expert, policy]), 0, discriminator.alpha_bars.shape[0])
        is_expert = torch.zeros_like(agent_error)
        is_expert[: expert.shape[0]] = 1.0
        entropy = F.binary_cross_entropy_with_logits(discriminator.logit(agent_error, expert_error), is_expert)
        return self.config.bce_weight * entropy + (expert_error * is_expert).mean(), entropy.detach()

    @staticmethod
    def rewarded(scores: torch.Tensor) -> torch.Tensor:
        """−log(1 − σ(logit)), the reference's GAIL reward, uncapped as there."""
        return F.softplus(scores)


def build(inputs: Inputs) -> AdversarialReward:
    discriminator = DiffusionDiscriminator(inputs.expert.shape[1], inputs.config.difo).to(inputs.expert.device)
    discriminator.fit_range(torch.cat([inputs.random, inputs.expert]))
    return adversarial_reward(inputs, DifoTrainer(discriminator, inputs.config.difo))


METHOD = Method("difo", "DIFO", "DIFO reward −log(1 − D)", reads_discriminator=False, caches_features=True, build=build,
                reward="−log(1 − D)")
