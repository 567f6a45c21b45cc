"""What the contrastive embeddings share (``infonce.py``, ``curl.py``): φ and a bilinear matrix W trained with
InfoNCE, the cross-entropy of picking each anchor's own positive out of the batch's positives by the score
``φ(a)ᵀ W k(p) / τ`` (the other positives are its negatives), as PW-DICE's ``Contrastive`` and CURL's ``CURL`` score
pairs. φ has ICVF's φ's shape (``nets.embedding_net``), so the ``Encoder`` downstream is the same.

An embedding here is a sampler (what a batch's anchors and positives are) and a key encoder k (what encodes the
positives); the loop, its logs, probes, checkpoints and resume are ``pretraining.pretrain``'s.
"""

from __future__ import annotations

from typing import Callable

import torch
import torch.nn.functional as F
from torch import nn

from .config import ContrastiveConfig
from .data import Episode
from .nets import Encoder, embedding_net, export_encoder
from .pretraining import EmbeddingResult, pretrain
from .probes import split_episodes

Sampler = Callable[[int], dict[str, torch.Tensor]]  # batch size -> {"anchor": (B, obs_dim), "positive": (B, obs_dim)}


def info_nce(anchor: torch.Tensor, positive: torch.Tensor, matrix: torch.Tensor, temperature: float) -> torch.Tensor:
    """Mean cross-entropy of row i's own positive i among all the batch's positives. (The references subtract each
    row's largest score first; cross-entropy does that itself.)"""
    logits = anchor @ matrix @ positive.T / temperature
    return F.cross_entropy(logits, torch.arange(len(anchor), device=anchor.device))


class BilinearContrast(nn.Module):
    def __init__(self, obs_dim: int, config: ContrastiveConfig):
        super().__init__()
        self.phi = embedding_net(1, obs_dim, config)
        dim = config.embedding_dim
        self.matrix = nn.Parameter(torch.rand(dim, dim))  # W as both references start it: uniform on [0, 1)


class ContrastiveLearner:
    """φ and W, trained by Adam on ``info_nce``; a subclass names the key encoder of the positives."""

    def __init__(self, obs_dim: int, config: ContrastiveConfig, device: torch.device | str):
        self.config, self.obs_dim = config, obs_dim
        self.model = BilinearContrast(obs_dim, config).to(device)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.lr)

    def keys(self, positive: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def update(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        anchor = self.model.phi(batch["anchor"])[0]
        loss = info_nce(anchor, self.keys(batch["positive"]), self.model.matrix, self.config.temperature)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if self.config.grad_clip > 0:
            nn.utils.clip_grad_norm_(self.model.parameters(), self.config.grad_clip)
        self.optimizer.step()
        return loss.detach()

    def encoder(self) -> Encoder:
        return export_encoder(self.model.phi, self.obs_dim, self.config).cpu()

    def state_dict(self) -> dict:
        return {"model": self.model.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.optimizer.load_state_dict(state["optimizer"])


def pretrain_contrastive(
    learner_class: type[ContrastiveLearner],
    sampler: Callable[[list[Episode], torch.device], Sampler],
    episodes: list[Episode],
    obs_dim: int,
    config: ContrastiveConfig,
    seed: int,
    device: torch.device | str = "cpu",
    **loop,
) -> EmbeddingResult:
    """A contrastive φ on the episodes ``split_episodes`` does not hold out for the probe, with the batches
    ``sampler(training episodes, device)`` draws; ``loop``: ``pretraining.pretrain``'s progress, resume,
    checkpoint, expert and stop arguments."""
    torch.manual_seed(seed)
    train, held_out = split_episodes(episodes, config.holdout_fraction, seed)
    draw = sampler(train, torch.device(device))
    learner = learner_class(obs_dim, config, device)
    return pretrain(learner, draw, config, held_out, device, **loop)
