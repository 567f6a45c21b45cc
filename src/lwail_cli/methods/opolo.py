"""OPOLO (Zhu, Lin, Dai & Zhou 2020, "Off-Policy Imitation Learning from Observations", NeurIPS 2020)
as its code runs it (illidanlab/opolo-code: ``stable_baselines/td3/td3opolo.py``, ``gail/idm.py``, the Hopper entry
of ``hyperparams/opolo.yml``), the code the LWAIL paper's OPOLO numbers come from.

TD3 on GAIfO's reward (this harness's adversary, ``methods/gaifo.py``, on the same schedule), with OPOLO's two
changes to what TD3 optimises:

- the min-max objective of its off-policy distribution matching: the critic's loss is half the twins' squared TD
  errors plus 2α(1−γ)·E[min Q(s, π(s))] over the batch's states (the reference's ``qf_init``: buffer states stand
  for the initial distribution), and the actor maximises that same term instead of Q₁;
- the inverse-action regulariser: the actor also minimises, with weight ``opolo.regularization``, its mean squared
  error in [-1, 1] units to the actions an inverse-dynamics model g infers for a batch of demo pairs. g is trained on
  data set I before the first step and every ``opolo.interval`` env steps on data set I and the played transitions.

The reference's policy loss also subtracts the clipped squared TD error, which does not depend on π (its backup is
held constant and its Q reads the buffer's actions), so it is left out. Evaluations, checkpoints and resume are the
online loop's (``training.online_loop``), bit for bit; docs/algorithm.md says where this departs from the reference.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch

from .. import learning_curve as curve
from ..inverse_dynamics import InverseDynamics, LabelledPairs
from ..replay import ReplayBuffer
from ..td3 import TD3
from ..training import TD3OnReward, online_loop
from . import gaifo
from .base import Inputs, Method, Session, Trained

if TYPE_CHECKING:
    from ..config import OpoloConfig, TD3Config
    from ..envs import EnvInfo
    from ..imitation import AdversarialReward


class OpoloTD3(TD3):
    """TD3 whose critic and actor losses are OPOLO's; the actor's regulariser reads ``demo_actions``, g's actions for
    the demo's pairs (set by ``OpoloLearner`` whenever g changes)."""

    def __init__(self, env: EnvInfo, config: TD3Config, device: torch.device, *, average_tau: float, opolo: OpoloConfig,
                 demo_states: torch.Tensor):
        super().__init__(env, config, device, average_tau=average_tau)
        self.initial_weight = 2 * opolo.alpha * (1 - config.gamma)
        self.regularization = opolo.regularization
        self.demo_states = demo_states
        self.demo_actions: torch.Tensor | None = None
        self.last_regularizer = torch.full((), float("nan"), device=self.device)

    def _initial_value(self, obs: torch.Tensor, actions: torch.Tensor, detach: bool) -> torch.Tensor:
        """E[min over the twins of Q(s, a)]: the initial-value term before its weight."""
        return self.critic(torch.cat([obs, actions], 1), detach=detach).amin(0).mean()

    def critic_loss(self, obs: torch.Tensor, q: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        with torch.no_grad():
            policy_actions = self.actor(obs)
        return 0.5 * super().critic_loss(obs, q, target) + self.initial_weight * self._initial_value(obs, policy_actions, detach=False)

    def actor_loss(self, obs: torch.Tensor) -> torch.Tensor:
        index = torch.randint(0, len(self.demo_states), (self.config.batch_size,), device=self.device)
        error = (torch.tanh(self.actor.net(self.demo_states[index])) - self.demo_actions[index]).square().mean()
        self.last_regularizer = error.detach()
        return -self.initial_weight * self._initial_value(obs, self.actor(obs), detach=True) + self.regularization * error

    def state_dict(self) -> dict:
        return super().state_dict() | {"last_regularizer": self.last_regularizer}

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.last_regularizer = state["last_regularizer"]


class OpoloLearner(TD3OnReward):
    """TD3 on the reward model, with g trained in rounds and the demo relabelled after each."""

    def __init__(self, agent: OpoloTD3, reward_model: AdversarialReward, inputs: Inputs, session: Session):
        config = inputs.config
        super().__init__(agent, reward_model, config.td3, config.train, session.info.id, session.seed, session.reference,
                         config.env.start_noise)
        self.opolo, self.demo = config.opolo, inputs.expert
        self.idm = InverseDynamics(inputs.expert.shape[1], session.info.act_dim, self.opolo, session.device)
        data = inputs.dataset
        self.pairs = LabelledPairs(inputs.encoder, data.observations, data.actions, data.next_observations, agent.actor,
                                   self.opolo.batch_size)

    def begin(self) -> None:
        """g on data set I alone, before the first env step (the reference's pre-training on its random steps)."""
        self.idm.fit(self.pairs, self.opolo.pretrain_steps, None)

    def learn(self, step: int, buffer: ReplayBuffer, ended: bool) -> None:
        if step % self.opolo.interval == 0:
            self.idm.fit(self.pairs, self.opolo.idm_steps, buffer)
            self.agent.demo_actions = None
        if self.agent.demo_actions is None:  # g changed, or the run resumed: the same g gives the same actions
            self.agent.demo_actions = self.idm.infer(self.demo)
        super().learn(step, buffer, ended)

    def evaluate(self) -> dict[str, float]:
        return super().evaluate() | {curve.IDM_LOSS: float(self.idm.last_loss), curve.BC_LOSS: float(self.agent.last_regularizer)}


def train(inputs: Inputs, session: Session) -> Trained:
    config, info = inputs.config, session.info
    reward_model = gaifo.build(inputs)  # D, then the agent, then g: each draws its initial weights from torch's generator
    agent = OpoloTD3(info, config.td3, session.device, average_tau=config.train.average_tau, opolo=config.opolo,
                     demo_states=inputs.expert_states)
    learner = OpoloLearner(agent, reward_model, inputs, session)
    buffer = ReplayBuffer(inputs.capacity, info.obs_dim, info.act_dim, session.device)
    state = online_loop(info.id, learner, buffer, config.train, session.seed,
                        {"agent": agent, "reward_model": reward_model, "idm": learner.idm}, resume=session.resume,
                        on_progress=session.on_progress, on_checkpoint=session.on_checkpoint, on_evaluation=session.on_evaluation,
                        progress_every=session.progress_every, start_noise=config.env.start_noise,
                        stop_requested=session.stop_requested)
    return Trained(state, agent.network(config.train.policy), reward_model.weights() | learner.idm.weights())


METHOD = Method("opolo", "OPOLO", "OPOLO: TD3 on its objective with GAIfO's reward −log(1 − D)", reads_discriminator=False,
                caches_features=True, reward="−log(1 − D)", train=train, reads_actions=True)
