"""CURL's contrastive state embedding (Laskin et al., 2020, "CURL: Contrastive Unsupervised Representations for
Reinforcement Learning"): the ``curl`` entry of ``embeddings.py``.

Anchor and positive are two augmented copies of the same state s of data set I: the anchor is encoded by φ, the
positive by the key encoder, an exponential moving average of φ that takes no gradient, and the pair is scored
bilinearly (``contrastive.info_nce``). CURL augments pixels by random crops, which do not apply to state vectors: each
copy here adds Gaussian noise of ``curl.noise`` times that dimension's std over the training episodes of data set I.
This follows MishaLaskin/curl, curl_sac.py's ``CURL`` (``compute_logits``, the key encoder's ``encoder_tau``); where it
departs: docs/algorithm.md, "Embeddings other than ICVF".
"""

from __future__ import annotations

import copy

import torch

from .config import CURLConfig
from .contrastive import ContrastiveLearner, Sampler, pretrain_contrastive
from .data import Episode, flatten
from .nets import soft_update
from .pretraining import EmbeddingResult


def noisy_copies(noise: float):
    """A sampler of two noisy copies of each drawn state, the noise ``noise`` times each dimension's std."""

    def sampler(episodes: list[Episode], device: torch.device) -> Sampler:
        states = torch.as_tensor(flatten(episodes).observations, device=device)
        scale = noise * states.std(0)

        def sample(batch_size: int) -> dict[str, torch.Tensor]:
            drawn = states[torch.randint(0, len(states), (batch_size,), device=device)]
            return {"anchor": drawn + torch.randn_like(drawn) * scale, "positive": drawn + torch.randn_like(drawn) * scale}

        return sample

    return sampler


class CURLLearner(ContrastiveLearner):
    def __init__(self, obs_dim: int, config: CURLConfig, device: torch.device | str):
        super().__init__(obs_dim, config, device)
        self.key_encoder = copy.deepcopy(self.model.phi).requires_grad_(False)

    def keys(self, positive: torch.Tensor) -> torch.Tensor:
        with torch.no_grad():
            return self.key_encoder(positive)[0]

    def update(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        loss = super().update(batch)
        with torch.no_grad():
            soft_update(self.key_encoder, self.model.phi, self.config.tau)
        return loss

    def state_dict(self) -> dict:
        return super().state_dict() | {"key_encoder": self.key_encoder.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.key_encoder.load_state_dict(state["key_encoder"])


def pretrain_curl(episodes: list[Episode], obs_dim: int, config: CURLConfig, seed: int, device: torch.device | str = "cpu",
                  **loop) -> EmbeddingResult:
    """φ trained to match two noisy copies of each state (``loop``: ``pretraining.pretrain``'s arguments)."""
    return pretrain_contrastive(CURLLearner, noisy_copies(config.noise), episodes, obs_dim, config, seed, device, **loop)
