"""PW-DICE's contrastive state embedding (Yan et al., 2024, "Offline Imitation from Observation via Primal Wasserstein
State Occupancy Matching"): the ``infonce`` entry of ``embeddings.py``.

The anchor is a state s of data set I, its positive the next state s', both encoded by φ itself (the gradient flows
through both sides), scored bilinearly (``contrastive.info_nce``); the gradient's norm is clipped at 1. This follows
KaiYan289/PW-DICE, PWDICE_continuous/contrastive_learning.py and NN.py's ``Contrastive``; where it departs (φ's shape,
the batch, a temperature): docs/algorithm.md, "Embeddings other than ICVF".
"""

from __future__ import annotations

import torch

from .config import InfoNCEConfig
from .contrastive import ContrastiveLearner, Sampler, pretrain_contrastive
from .data import Episode, transition_pairs
from .pretraining import EmbeddingResult


def next_states(episodes: list[Episode], device: torch.device) -> Sampler:
    """Batches of transitions: s as the anchor, s' as its positive."""
    states, successors = (torch.as_tensor(side, device=device) for side in transition_pairs(episodes))

    def sample(batch_size: int) -> dict[str, torch.Tensor]:
        index = torch.randint(0, len(states), (batch_size,), device=device)
        return {"anchor": states[index], "positive": successors[index]}

    return sample


class InfoNCELearner(ContrastiveLearner):
    def keys(self, positive: torch.Tensor) -> torch.Tensor:
        return self.model.phi(positive)[0]


def pretrain_infonce(episodes: list[Episode], obs_dim: int, config: InfoNCEConfig, seed: int, device: torch.device | str = "cpu",
                     **loop) -> EmbeddingResult:
    """φ trained to pick each state's next state out of the batch's (``loop``: ``pretraining.pretrain``'s arguments)."""
    return pretrain_contrastive(InfoNCELearner, next_states, episodes, obs_dim, config, seed, device, **loop)
