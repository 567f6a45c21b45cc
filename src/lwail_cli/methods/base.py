"""What every imitation method is: its registry entry (``Method``), what it is built from (``Inputs``) and what it
builds (a ``Learner``, the reward model the TD3 loop runs). The registry itself: ``methods/__init__.py``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Protocol

from ..training import RewardModel

if TYPE_CHECKING:
    import torch

    from ..config import CriticConfig, ImitationConfig
    from ..discriminator import Critic
    from ..icvf import Encoder


class Learner(RewardModel, Protocol):
    """A ``training.RewardModel`` that also says which learned weights its policy artifact keeps."""

    def weights(self) -> dict[str, dict]:
        """File name -> state dict of each network the artifact keeps (none for a learner that trains nothing)."""


@dataclass(frozen=True)
class Inputs:
    """What the stage hands a method: the same frozen φ, demo and diagnostic pairs whatever the method."""

    config: ImitationConfig
    encoder: Encoder  # φ, frozen (the identity for raw states)
    expert: torch.Tensor  # the expert's pair features [φ(s), φ(s') − φ(s)], in the demo's order
    random: torch.Tensor  # random-policy pair features, only for diagnostics
    capacity: int  # the replay buffer's
    critic: Critic | None = None  # the warmed-up f, for a method that reads a discriminator artifact
    critic_config: CriticConfig | None = None  # the settings f was warmed up with


@dataclass(frozen=True)
class Method:
    name: str  # as --method names it (one of config.METHODS)
    label: str  # its public name, in figures and tables
    trained_on: str  # what its policy artifacts say they were trained on
    reads_discriminator: bool  # needs a warmed-up f (`lwail warmup-disc`, --disc); a method that does not refuses one
    caches_features: bool  # keeps every buffered pair's features (the replay memory check counts them)
    build: Callable[[Inputs], Learner]
    reward: str  # the reward TD3 is given, as figures and their legends write it (e.g. σ(−f))
