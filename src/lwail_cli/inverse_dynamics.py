"""The inverse-dynamics model g that infers the action of a state pair, what it is trained on, and behaviour cloning
of a policy on the actions it infers: BCO's two regressions (methods/bco.py) and OPOLO's regulariser (methods/opolo.py).
We follow OPOLO's ``stable_baselines/gail/idm.py`` (``InverseModel``) and ``td3/td3bco.py`` (``_train_policy``);
docs/algorithm.md, "Baselines in the same harness".

Actions are regressed in [-1, 1] units, ``(a − offset) / scale`` of the actor's bounds, as the reference scales them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
from torch import nn

from .discriminator import transition_features
from .nets import mlp

if TYPE_CHECKING:
    from .config import InverseDynamicsSettings
    from .icvf import Encoder
    from .replay import ReplayBuffer
    from .td3 import Actor

STD_FLOOR = 1e-2  # the reference's RunningMeanStd: no input is divided by a spread below √0.01 = 0.1
COUNT_PRIOR = 1e-2  # its epsilon: the prior count (and sum of squares) the running statistics start from


class RunningStandardizer:
    """Inputs standardised by the running mean and spread of every batch trained on so far (the reference's
    ``RunningMeanStd``, its sums in float64): ``(x − mean) / sqrt(max(E[x²] − mean², 0.01))``."""

    def __init__(self, width: int, device: torch.device):
        self.sum = torch.zeros(width, dtype=torch.float64, device=device)
        self.sum_squares = torch.full((width,), COUNT_PRIOR, dtype=torch.float64, device=device)
        self.count = torch.full((), COUNT_PRIOR, dtype=torch.float64, device=device)

    def update(self, batch: torch.Tensor) -> None:
        wide = batch.double()
        self.sum += wide.sum(0)
        self.sum_squares += wide.square().sum(0)
        self.count += len(batch)

    def __call__(self, batch: torch.Tensor) -> torch.Tensor:
        mean = (self.sum / self.count).float()
        spread = ((self.sum_squares / self.count).float() - mean.square()).clamp(min=STD_FLOOR).sqrt()
        return (batch - mean) / spread

    def state_dict(self) -> dict:
        return {"sum": self.sum.clone(), "sum_squares": self.sum_squares.clone(), "count": self.count.clone()}

    def load_state_dict(self, state: dict) -> None:
        self.sum.copy_(state["sum"])
        self.sum_squares.copy_(state["sum_squares"])
        self.count.copy_(state["count"])


class InverseDynamics:
    """â = g(standardised pair features): a tanh MLP (``bco.idm_hidden``), trained with Adam (``bco.idm_lr``) on the
    mean squared error plus ``bco.idm_weight_decay``·½Σw² over every weight and bias (TF's l2_loss, as the
    reference adds it). The standardiser takes in each batch before the step on it, as the reference's does."""

    FILE = "inverse_dynamics.safetensors"

    def __init__(self, width: int, act_dim: int, config: InverseDynamicsSettings, device: torch.device):
        self.model = mlp(width, config.idm_hidden, act_dim, activation=nn.Tanh).to(device)
        self.standardize = RunningStandardizer(width, device)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.idm_lr)
        self.weight_decay = config.idm_weight_decay
        self.last_loss = torch.full((), float("nan"), device=device)

    @torch.no_grad()
    def infer(self, features: torch.Tensor) -> torch.Tensor:
        """The action, in [-1, 1] units, of each pair."""
        return self.model(self.standardize(features))

    def fit(self, pairs: LabelledPairs, steps: int, buffer: ReplayBuffer | None) -> None:
        """``steps`` gradient steps on batches of ``pairs`` (data set I alone when ``buffer`` is None)."""
        for _ in range(steps):
            self.step(*pairs.sample(buffer))

    def step(self, features: torch.Tensor, actions: torch.Tensor) -> None:
        """One gradient step on a batch of pair features and the actions taken between them ([-1, 1] units)."""
        self.standardize.update(features)
        error = (self.model(self.standardize(features)) - actions).square().mean()
        penalty = sum(parameter.square().sum() for parameter in self.model.parameters()) / 2
        self.optimizer.zero_grad(set_to_none=True)
        (error + self.weight_decay * penalty).backward()
        self.optimizer.step()
        self.last_loss = error.detach()

    def weights(self) -> dict[str, dict]:
        """The file a policy artifact keeps g in: its weights with its running statistics (``standardize.*``)."""
        return {self.FILE: self.model.state_dict()
                | {f"standardize.{name}": tensor for name, tensor in self.standardize.state_dict().items()}}

    def state_dict(self) -> dict:
        return {"model": self.model.state_dict(), "optimizer": self.optimizer.state_dict(),
                "standardize": self.standardize.state_dict(), "last_loss": self.last_loss}

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.standardize.load_state_dict(state["standardize"])
        self.last_loss = state["last_loss"]


class LabelledPairs:
    """What g is trained on: data set I's pairs with the random policy's actions, and every transition the run has
    played, drawn uniformly from both (the reference's replay buffer holds its random steps, then the policy's)."""

    def __init__(self, encoder: Encoder, observations: torch.Tensor, actions: torch.Tensor, next_observations: torch.Tensor,
                 actor: Actor, batch_size: int):
        """g reads a pair as the frozen ``encoder``'s features ``[φ(s), φ(s') − φ(s)]``; the actions are in the env's bounds."""
        self.encoder, self.actor, self.batch_size = encoder, actor, batch_size
        self.data_features = self.features(observations, next_observations)
        self.data_actions = unit_actions(actor, actions)

    @torch.no_grad()
    def features(self, states: torch.Tensor, next_states: torch.Tensor) -> torch.Tensor:
        return transition_features(self.encoder, states, next_states)

    def sample(self, buffer: ReplayBuffer | None) -> tuple[torch.Tensor, torch.Tensor]:
        """A batch of pair features and their [-1, 1] actions from data set I and the transitions ``buffer`` holds."""
        known = len(self.data_actions)
        played = 0 if buffer is None else buffer.size
        index = torch.randint(0, known + played, (self.batch_size,), device=self.data_actions.device)
        first = index.clamp(max=known - 1)  # the rows drawn from data set I (the others are replaced below)
        features, actions = self.data_features[first], self.data_actions[first]
        if played:
            buffer.flush()
            mine = index >= known
            rows = index[mine] - known
            storage = buffer.storage
            features[mine] = self.features(storage["observations"][rows], storage["next_observations"][rows])
            actions[mine] = unit_actions(self.actor, storage["actions"][rows])
        return features, actions


class BehaviourCloning:
    """The actor regressed onto target actions by mean squared error in [-1, 1] units (its tanh output before the
    bounds' scale and offset), with Adam (``bco.lr``): the reference's policy loss."""

    def __init__(self, actor: Actor, lr: float):
        self.actor = actor
        self.optimizer = torch.optim.Adam(actor.parameters(), lr=lr)
        self.last_loss = torch.full((), float("nan"), device=actor.scale.device)

    def step(self, states: torch.Tensor, actions: torch.Tensor) -> None:
        error = (torch.tanh(self.actor.net(states)) - actions).square().mean()
        self.optimizer.zero_grad(set_to_none=True)
        error.backward()
        self.optimizer.step()
        self.last_loss = error.detach()

    def state_dict(self) -> dict:
        return {"actor": self.actor.state_dict(), "optimizer": self.optimizer.state_dict(), "last_loss": self.last_loss}

    def load_state_dict(self, state: dict) -> None:
        self.actor.load_state_dict(state["actor"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.last_loss = state["last_loss"]


def unit_actions(actor: Actor, actions: torch.Tensor) -> torch.Tensor:
    """Actions in the env's bounds to [-1, 1] units (the reference's ``scale_action``)."""
    return (actions - actor.offset) / actor.scale
