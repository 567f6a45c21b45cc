"""What every imitation method is: its registry entry (``Method``), what it is built from (``Inputs``) and what it
builds: a ``Learner``, the reward model the TD3 loop runs, or, for a method with a loop of its own, the ``Trained``
policy that loop ends with, given the run's ``Session``. The registry itself: ``methods/__init__.py``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Protocol

from ..imitation import AdversarialReward
from ..training import RewardModel

if TYPE_CHECKING:
    import torch

    from ..config import CriticConfig, ImitationConfig
    from ..discriminator import Critic
    from ..envs import EnvInfo
    from ..evaluation import Reference
    from ..icvf import Encoder
    from ..imitation import Adversary
    from ..training import RunState


class Learner(RewardModel, Protocol):
    """A ``training.RewardModel`` that also says which learned weights its policy artifact keeps."""

    def weights(self) -> dict[str, dict]:
        """File name -> state dict of each network the artifact keeps (none for a learner that trains nothing)."""


@dataclass(frozen=True)
class Transitions:
    """Data set I's transitions with the random policy's actions, as tensors on the run's device."""

    observations: torch.Tensor
    actions: torch.Tensor
    next_observations: torch.Tensor


@dataclass(frozen=True)
class Inputs:
    """What the stage hands a method: the same frozen φ, demo and diagnostic pairs whatever the method."""

    config: ImitationConfig
    encoder: Encoder  # φ, frozen (the identity for raw states)
    expert: torch.Tensor  # the expert's pair features [φ(s), φ(s') − φ(s)], in the demo's order
    random: torch.Tensor  # random-policy pair features of data set I: diagnostics, and the range DIFO scales φ by
    capacity: int  # the replay buffer's
    critic: Critic | None = None  # the warmed-up f, for a method that reads a discriminator artifact
    critic_config: CriticConfig | None = None  # the settings f was warmed up with
    expert_states: torch.Tensor | None = None  # the raw s of each expert pair, in the same order (what a policy acts on)
    dataset: Transitions | None = None  # data set I with its actions, for a method that reads them (``Method.reads_actions``)


@dataclass(frozen=True)
class Session:
    """What the stage hands a method that runs its own loop: the task, the seed (torch is seeded with it already),
    the device, the reference scores, the checkpoint a resumed run goes on from, and where the loop reports
    (``training.online_loop``'s callbacks)."""

    info: EnvInfo
    seed: int
    device: torch.device
    reference: Reference | None
    resume: dict | None
    on_checkpoint: Callable[[dict], None]
    on_evaluation: Callable[[RunState], None]
    on_progress: Callable[[int, RunState], None] | None
    progress_every: int
    stop_requested: Callable[[], bool]  # asked every progress_every steps: checkpoint and stop (``training.online_loop``)


@dataclass(frozen=True)
class Trained:
    """What an imitation run ends with, whatever trained it: its run state (curve, best, wall time), the policy
    network the artifact keeps as its actor, and the other networks it keeps (file name -> state dict)."""

    state: RunState
    actor: torch.nn.Module
    weights: dict[str, dict]


@dataclass(frozen=True)
class Method:
    name: str  # as --method names it (one of config.METHODS)
    label: str  # its public name, in figures and tables
    trained_on: str  # what its policy artifacts say they were trained on
    reads_discriminator: bool  # needs a warmed-up f (`lwail warmup-disc`, --disc); a method that does not refuses one
    caches_features: bool  # keeps every buffered pair's features (the replay memory check counts them)
    reward: str  # the reward TD3 is given, as figures and their legends write it (e.g. σ(−f)); a method without one says so
    build: Callable[[Inputs], Learner] | None = None  # the reward learner the TD3 loop runs, or
    train: Callable[[Inputs, Session], Trained] | None = None  # a loop of its own, run instead of TD3's
    reads_actions: bool = False  # learns from data set I's actions: a data set without them is refused up front
    trains_td3: bool = True  # its policy is TD3's actor, so td3.random_steps and td3.learning_starts apply (not BCO's)

    def __post_init__(self) -> None:
        if (self.build is None) == (self.train is None):
            raise ValueError(f"method {self.name}: give build (a reward learner for the TD3 loop) or train (its own loop), one of them")


def adversarial_reward(inputs: Inputs, trainer: Adversary) -> AdversarialReward:
    """An adversary's reward on the run's schedule (every ``update_every`` env steps, ``update_steps`` updates): LWAIL's, GAIfO's, DIFO's."""
    config = inputs.config
    return AdversarialReward(inputs.encoder, trainer, inputs.expert, inputs.capacity, update_every=config.update_every,
                             update_steps=config.update_steps, random_features=inputs.random)
