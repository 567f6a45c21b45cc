"""ICVF pre-training (Ghosh et al., 2023) of the state embedding φ, and its quality probe.

``V(s, s+, z) = Σ A(t ⊙ φ(s)) ⊙ B(t ⊙ ψ(s+))`` with ``t = T(ψ(z))``, an ensemble of independent
value functions trained by expectile regression on action-free transitions (docs/algorithm.md, stage 1).
All ensemble members run as one batched matmul; goal sampling happens on the compute device.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd
import torch
from torch import nn

from .config import ICVFConfig
from .data import Episode, flatten, transition_pairs
from .discriminator import transition_features
from .evaluation import spearman
from .nets import StackedMLP, soft_update
from .resumable import Stopwatch, capture, checkpoint_due, restore


def _embedding_net(members: int, in_dim: int, config: ICVFConfig) -> StackedMLP:
    return StackedMLP(members, in_dim, config.hidden, config.embedding_dim, activation="gelu", activate_final=True, layer_norm=config.layer_norm)


class ICVF(nn.Module):
    """An ensemble of multilinear intention-conditioned value functions."""

    def __init__(self, obs_dim: int, config: ICVFConfig):
        super().__init__()
        members, dim = config.ensemble, config.embedding_dim
        self.phi = _embedding_net(members, obs_dim, config)
        self.psi = _embedding_net(members, obs_dim, config)
        self.intention = _embedding_net(members, dim, config)  # T
        self.matrix_a = StackedMLP(members, dim, (), dim)
        self.matrix_b = StackedMLP(members, dim, (), dim)

    def value(self, phi_s: torch.Tensor, psi_outcome: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """V for embedded inputs, each (members, B, dim); returns (members, B)."""
        return (self.matrix_a(t * phi_s) * self.matrix_b(t * psi_outcome)).sum(-1)

    def values_for_targets(self, phi_s, phi_next, psi_outcome, psi_intention, t):
        """V(s', s+, z), V(s', z, z) and V(s, z, z), sharing the projection of φ(s') and of ψ(z)."""
        a_next = self.matrix_a(t * phi_next)
        b_intention = self.matrix_b(t * psi_intention)
        return (
            (a_next * self.matrix_b(t * psi_outcome)).sum(-1),
            (a_next * b_intention).sum(-1),
            (self.matrix_a(t * phi_s) * b_intention).sum(-1),
        )


class Encoder(nn.Module):
    """The frozen φ used downstream: member 0 of the trained ensemble, or the identity."""

    def __init__(self, obs_dim: int, config: ICVFConfig | None):
        super().__init__()
        self.net = _embedding_net(1, obs_dim, config) if config is not None else None
        self.dim = config.embedding_dim if config is not None else obs_dim

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return obs if self.net is None else self.net(obs)[0]


def export_encoder(model: ICVF, obs_dim: int, config: ICVFConfig) -> Encoder:
    with torch.random.fork_rng(devices=[]):  # its throw-away initialization must not shift training's random stream
        encoder = Encoder(obs_dim, config)
    member_zero = {name: tensor[0:1].detach().clone() for name, tensor in model.phi.state_dict().items()}
    encoder.net.load_state_dict(member_zero)
    return encoder.requires_grad_(False).eval()


class GoalSampler:
    """Batches of (s, s', s+, z) indices with ICVF's goal mixture, drawn on the device."""

    def __init__(self, episodes: list[Episode], config: ICVFConfig, device: torch.device):
        flat = flatten(episodes)
        self.config = config
        self.observations = torch.as_tensor(flat.observations, device=device)
        self.episode_end = torch.as_tensor(flat.episode_end, device=device)
        self.starts = torch.as_tensor(np.flatnonzero(flat.has_successor), device=device)
        self.device = device

    def _goals(self, index: torch.Tensor) -> torch.Tensor:
        cfg = self.config
        u = torch.rand(index.shape, device=self.device)
        later = index + 1 + (torch.rand(index.shape, device=self.device) * (self.episode_end[index] - index)).long()
        anywhere = torch.randint(0, len(self.observations), index.shape, device=self.device)
        return torch.where(u < cfg.p_goal_current, index, torch.where(u < cfg.p_goal_current + cfg.p_goal_trajectory, later, anywhere))

    def sample(self, batch_size: int) -> dict[str, torch.Tensor]:
        index = self.starts[torch.randint(0, len(self.starts), (batch_size,), device=self.device)]
        intention = self._goals(index)
        outcome = torch.where(torch.rand(index.shape, device=self.device) < self.config.p_outcome_is_goal, intention, self._goals(index))
        reached_outcome = (outcome == index).float()
        reached_intention = (intention == index).float()
        obs = self.observations
        return {
            "s": obs[index], "next_s": obs[index + 1], "outcome": obs[outcome], "intention": obs[intention],
            "outcome_reward": reached_outcome - 1.0, "outcome_mask": 1.0 - reached_outcome,
            "intention_reward": reached_intention - 1.0, "intention_mask": 1.0 - reached_intention,
        }


class ICVFLearner:
    def __init__(self, obs_dim: int, config: ICVFConfig, device: torch.device | str = "cpu"):
        self.config = config
        self.model = ICVF(obs_dim, config).to(device)
        self.target = copy.deepcopy(self.model).requires_grad_(False)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.lr, fused=torch.device(device).type in ("cpu", "cuda"))

    def loss(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        cfg = self.config
        with torch.no_grad():
            target = self.target
            phi_s, phi_next = target.phi(torch.cat([batch["s"], batch["next_s"]])).chunk(2, dim=1)
            psi_outcome, psi_intention = target.psi(torch.cat([batch["outcome"], batch["intention"]])).chunk(2, dim=1)
            t = target.intention(psi_intention)
            next_v_outcome, next_v_intention, v_intention = target.values_for_targets(phi_s, phi_next, psi_outcome, psi_intention, t)
            q_outcome = batch["outcome_reward"] + cfg.gamma * batch["outcome_mask"] * next_v_outcome
            q_intention = batch["intention_reward"] + cfg.gamma * batch["intention_mask"] * next_v_intention.amin(0)
            advantage = q_intention - v_intention.mean(0)
            weight = torch.where(advantage >= 0, cfg.expectile, 1.0 - cfg.expectile)
        model = self.model
        psi_outcome, psi_intention = model.psi(torch.cat([batch["outcome"], batch["intention"]])).chunk(2, dim=1)
        v = model.value(model.phi(batch["s"]), psi_outcome, model.intention(psi_intention))
        return (weight * (q_outcome - v).square()).mean(1).sum()

    def update(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        loss = self.loss(batch)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        with torch.no_grad():
            soft_update(self.target, self.model, self.config.tau)
        return loss.detach()

    def state_dict(self) -> dict:
        return {"model": self.model.state_dict(), "target": self.target.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.model.load_state_dict(state["model"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])


# ------------------------------------------------------------------------------ quality probe
def split_episodes(episodes: list[Episode], holdout_fraction: float, seed: int) -> tuple[list[Episode], list[Episode]]:
    """Hold out whole episodes (with at least 3 observations) for the probe."""
    candidates = [i for i, e in enumerate(episodes) if len(e.observations) >= 3]
    count = max(1, int(round(holdout_fraction * len(episodes)))) if candidates else 0
    held = set(np.random.default_rng(seed).permutation(candidates)[:count].tolist())
    train = [e for i, e in enumerate(episodes) if i not in held]
    return (train or episodes), [episodes[i] for i in sorted(held)]


def probe_spearman(encode: Callable[[torch.Tensor], torch.Tensor], episodes: list[Episode], max_points: int = 200) -> float:
    """Rank correlation of ``‖φ(s_i) − φ(s_j)‖`` with ``|i − j|`` over pairs inside each episode."""
    latent, temporal = [], []
    for episode in episodes:
        steps = np.unique(np.linspace(0, len(episode.observations) - 1, min(max_points, len(episode.observations))).astype(int))
        with torch.no_grad():
            z = encode(torch.as_tensor(episode.observations[steps], dtype=torch.float32))
        i, j = np.triu_indices(len(steps), k=1)
        latent.append(torch.linalg.vector_norm(z[i] - z[j], dim=-1).cpu().numpy())
        temporal.append(np.abs(steps[i] - steps[j]).astype(float))
    if not latent:
        return float("nan")
    return spearman(np.concatenate(latent), np.concatenate(temporal))


@torch.no_grad()
def probe_critic_needs(encode: Callable[[torch.Tensor], torch.Tensor], expert: list[Episode], random: list[Episode], max_pairs: int = 2000) -> dict[str, float]:
    """What the critic needs from φ, on the critic's own input ``[φ(s), φ(s') − φ(s)]``:

    - ``separation_auc``: how often a random-policy pair lies farther from the first expert trajectory
      than a pair of another expert trajectory does (1 = always, 0.5 = chance; NaN with one trajectory);
    - ``progress_spearman``: rank correlation of ``‖φ(s_t) − φ(s_T)‖`` with the steps to go ``T − t``
      along the first expert trajectory (1 = distance to the goal shrinks at every step)."""

    def pairs(episodes: list[Episode]) -> torch.Tensor:
        states, next_states = (torch.as_tensor(side) for side in transition_pairs(episodes))
        pick = torch.linspace(0, len(states) - 1, min(max_pairs, len(states))).long()
        return transition_features(encode, states[pick], next_states[pick])

    def nearest(candidates: torch.Tensor, reference: torch.Tensor) -> np.ndarray:
        return torch.cat([torch.cdist(chunk, reference).amin(1) for chunk in candidates.split(1024)]).numpy()

    first = expert[0]
    z = encode(torch.as_tensor(first.observations, dtype=torch.float32))
    to_goal = torch.linalg.vector_norm(z - z[-1], dim=-1).numpy()
    progress = spearman(to_goal[:-1], np.arange(len(to_goal) - 1, 0, -1).astype(float))
    separation = float("nan")
    if len(expert) > 1 and random:
        reference = pairs([first])
        near_expert, near_random = nearest(pairs(expert[1:]), reference), nearest(pairs(random), reference)
        ranks = pd.Series(np.concatenate([near_expert, near_random])).rank().to_numpy()[len(near_expert):]
        separation = float((ranks.sum() - len(near_random) * (len(near_random) + 1) / 2) / (len(near_random) * len(near_expert)))
    return {"separation_auc": separation, "progress_spearman": progress}


@dataclass
class ICVFResult:
    encoder: Encoder
    log: pd.DataFrame  # step, wall_time, loss, probe_latent (and separation_auc, progress_spearman given the expert)
    probe_latent: float
    probe_raw: float


def pretrain_icvf(
    episodes: list[Episode],
    obs_dim: int,
    config: ICVFConfig,
    seed: int,
    device: torch.device | str = "cpu",
    on_progress: Callable[[int, float | None], None] | None = None,
    resume: dict | None = None,
    on_checkpoint: Callable[[dict], None] | None = None,
    expert: list[Episode] | None = None,
) -> ICVFResult:
    """ICVF on the episodes, reporting every step to ``on_progress`` (with the loss at a logged step, else None);
    every ``config.checkpoint_every`` steps ``on_checkpoint`` gets the whole state
    (``resumable.capture``), and ``resume`` (such a state) continues bit for bit. Given the ``expert`` episodes, every log row also probes what
    the critic needs (``probe_critic_needs``), so one long run shows which budget φ needs."""
    torch.manual_seed(seed)
    train, held_out = split_episodes(episodes, config.holdout_fraction, seed)
    sampler = GoalSampler(train, config, torch.device(device))
    learner = ICVFLearner(obs_dim, config, device)
    parts = {"learner": learner}
    rows, running, first, clock = [], torch.zeros((), device=device), 1, Stopwatch()
    if resume is not None:
        restore(resume, parts)
        rows, first, clock = list(resume["rows"]), resume["step"] + 1, Stopwatch(resume["wall_time"])
        running = resume["running"].to(device)
    for step in range(first, config.steps + 1):
        running += learner.update(sampler.sample(config.batch_size))
        logged = None
        if step % config.log_every == 0 or step == config.steps:
            span = step - (rows[-1]["step"] if rows else 0)  # the steps ``running`` summed: a resume may change log_every
            encoder = export_encoder(learner.model, obs_dim, config).cpu()
            loss = running.item() / span
            rows.append({"step": step, "wall_time": clock.elapsed(), "loss": loss, "probe_latent": probe_spearman(encoder, held_out)}
                        | ({} if expert is None else probe_critic_needs(encoder, expert, held_out)))
            running.zero_()
            logged = loss
        if on_progress is not None:
            on_progress(step, logged)
        if on_checkpoint is not None and checkpoint_due(step, config.checkpoint_every, config.steps):
            on_checkpoint(capture(parts, rows=list(rows), step=step, wall_time=clock.elapsed(), running=running.detach().cpu().clone()))
    encoder = export_encoder(learner.model, obs_dim, config).cpu()
    return ICVFResult(encoder, pd.DataFrame(rows), probe_spearman(encoder, held_out), probe_spearman(lambda x: x, held_out))
