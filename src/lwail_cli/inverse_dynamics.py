"""BCO's two regressions (methods/bco.py): an inverse-dynamics model that infers the action of a state pair, and
behaviour cloning of a policy on the actions it infers. We follow OPOLO's ``stable_baselines/gail/idm.py``
(``InverseModel``) and ``td3/td3bco.py`` (``_train_policy``); docs/algorithm.md, "Baselines in the same harness".

Actions are regressed in [-1, 1] units, ``(a − offset) / scale`` of the actor's bounds, as the reference scales them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
from torch import nn

from .nets import mlp

if TYPE_CHECKING:
    from .config import BcoConfig
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

    def __init__(self, width: int, act_dim: int, config: BcoConfig, device: torch.device):
        self.model = mlp(width, config.idm_hidden, act_dim, activation=nn.Tanh).to(device)
        self.standardize = RunningStandardizer(width, device)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.idm_lr)
        self.weight_decay = config.idm_weight_decay
        self.last_loss = torch.full((), float("nan"), device=device)

    @torch.no_grad()
    def infer(self, features: torch.Tensor) -> torch.Tensor:
        """The action, in [-1, 1] units, of each pair."""
        return self.model(self.standardize(features))

    def step(self, features: torch.Tensor, actions: torch.Tensor) -> None:
        """One gradient step on a batch of pair features and the actions taken between them ([-1, 1] units)."""
        self.standardize.update(features)
        error = (self.model(self.standardize(features)) - actions).square().mean()
        penalty = sum(parameter.square().sum() for parameter in self.model.parameters()) / 2
        self.optimizer.zero_grad(set_to_none=True)
        (error + self.weight_decay * penalty).backward()
        self.optimizer.step()
        self.last_loss = error.detach()

    def state_dict(self) -> dict:
        return {"model": self.model.state_dict(), "optimizer": self.optimizer.state_dict(),
                "standardize": self.standardize.state_dict(), "last_loss": self.last_loss}

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.standardize.load_state_dict(state["standardize"])
        self.last_loss = state["last_loss"]


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
