"""BCO(α) (Torabi, Warnell & Stone 2018, "Behavioral Cloning from Observation", IJCAI; arXiv:1805.01954) as OPOLO's
code runs it (illidanlab/opolo-code: ``stable_baselines/td3/td3bco.py`` and ``gail/idm.py``), the code the LWAIL
paper's BCO numbers come from. A loop of its own, not a reward for TD3:

1. pre-demonstration: an inverse-dynamics model g(s, s') → a is trained on data set I, the uniformly random policy's
   transitions with their actions (``bco.pretrain_steps`` steps: the reference's 100/α on its first 10,000 random
   env steps, which data set I stands for here); then the policy is cloned (``bco.bc_steps``) on the demo's pairs,
   each labelled with the action g infers for it;
2. post-demonstration (the α of BCO(α)): the cloned policy plays with Gaussian noise (``bco.exploration_noise``),
   counted in the run's ``train.steps``; every ``bco.interval`` env steps g takes ``bco.idm_steps`` more steps on
   data set I and every transition played so far, and the policy ``bco.bc_steps`` more on the demo's actions as g
   now infers them.

g reads the pair features ``[φ(s), φ(s') − φ(s)]`` (raw states through the identity, as every method reads its
pairs); the policy acts on raw states and is the same ``Actor`` (``td3.hidden``) that `lwail eval` loads for every
method. Evaluations, checkpoints and resume are the online loop's (``training.online_loop``), bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from .. import learning_curve as curve
from ..inverse_dynamics import BehaviourCloning, InverseDynamics, LabelledPairs
from ..replay import ReplayBuffer
from ..td3 import Actor
from ..training import evaluate_actor, online_loop
from .base import Inputs, Method, Session, Trained

if TYPE_CHECKING:
    import gymnasium as gym


class BehaviouralCloningFromObservation:
    """BCO as the online loop's agent (``training.OnlineAgent``): it acts with the cloned policy and learns in rounds."""

    def __init__(self, inputs: Inputs, session: Session):
        config = inputs.config
        self.bco, self.train, self.device = config.bco, config.train, session.device
        self.actor = Actor.for_env(session.info, config.td3.hidden).to(self.device)
        self.cloning = BehaviourCloning(self.actor, self.bco.lr)
        self.idm = InverseDynamics(inputs.expert.shape[1], session.info.act_dim, self.bco, self.device)
        data = inputs.dataset
        self.pairs = LabelledPairs(inputs.encoder, data.observations, data.actions, data.next_observations, self.actor, self.bco.batch_size)
        self.expert, self.expert_states = inputs.expert, inputs.expert_states
        self._evaluation = (session.info.id, session.seed, session.reference, config.env.start_noise)

    def begin(self) -> None:
        """Pre-demonstration: g on data set I alone, then the first cloning."""
        self.idm.fit(self.pairs, self.bco.pretrain_steps, None)
        self._clone()

    def act(self, obs: np.ndarray, step: int, env: gym.Env, noise: np.random.Generator) -> np.ndarray:
        low, high = env.action_space.low, env.action_space.high
        return np.clip(self._policy(obs) + noise.normal(0.0, self.bco.exploration_noise * (high - low) / 2), low, high)

    def learn(self, step: int, buffer: ReplayBuffer, ended: bool) -> None:
        if step % self.bco.interval == 0:
            self.idm.fit(self.pairs, self.bco.idm_steps, buffer)
            self._clone()

    def _clone(self) -> None:
        """``bco.bc_steps`` steps of the policy on demo states, each labelled with the action g infers for its pair
        (inferred once: g does not change within a round, where the reference infers each batch's again)."""
        targets = self.idm.infer(self.expert)
        for _ in range(self.bco.bc_steps):
            index = torch.randint(0, len(targets), (self.bco.batch_size,), device=self.device)
            self.cloning.step(self.expert_states[index], targets[index])

    @torch.inference_mode()
    def _policy(self, obs: np.ndarray) -> np.ndarray:
        return self.actor(torch.as_tensor(obs, dtype=torch.float32, device=self.device)).cpu().numpy()

    def evaluate(self) -> dict[str, float]:
        row, _ = evaluate_actor(self._policy, self.train, *self._evaluation)
        return row | {curve.IDM_LOSS: float(self.idm.last_loss), curve.BC_LOSS: float(self.cloning.last_loss)}

    def policy(self) -> torch.nn.Module:
        return self.actor


def train(inputs: Inputs, session: Session) -> Trained:
    config, info = inputs.config, session.info
    agent = BehaviouralCloningFromObservation(inputs, session)
    buffer = ReplayBuffer(inputs.capacity, info.obs_dim, info.act_dim, session.device)
    state = online_loop(info.id, agent, buffer, config.train, session.seed, {"idm": agent.idm, "cloning": agent.cloning},
                        resume=session.resume, on_progress=session.on_progress, on_checkpoint=session.on_checkpoint,
                        on_evaluation=session.on_evaluation, progress_every=session.progress_every, start_noise=config.env.start_noise,
                        stop_requested=session.stop_requested)
    return Trained(state, agent.actor, agent.idm.weights())


METHOD = Method("bco", "BCO", "BCO: behaviour cloning of the demo's inferred actions", reads_discriminator=False,
                caches_features=False, reward="none (cloned actions)", train=train,
                reads_actions=True, trains_td3=False)
