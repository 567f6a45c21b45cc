"""The one loop that plays a policy in an environment: collection, recording and evaluation all use it.

Episodes run side by side, one environment each, and the policy is called once per step on the batch
of live observations (one matmul instead of one per episode). Each environment is reset with its own
seed and its action space seeded with it, so a rollout is reproducible episode by episode.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .data import Episode
from .envs import make_env

Policy = Callable[[np.ndarray], np.ndarray]  # a batch of float32 observations -> a batch of actions


@dataclass
class Rollouts:
    returns: np.ndarray  # (episodes,) float64 true returns, in seed order
    episodes: list[Episode]  # the episodes themselves when recorded (else empty), in seed order
    terminated: np.ndarray | None = None  # (episodes,) bool: ended by the environment (a fall), not by its time limit
    successes: np.ndarray | None = None  # (episodes,) bool: the env's info["success"] at any step; None where it reports none

    @property
    def success_rate(self) -> float | None:
        """The fraction of episodes that succeeded (the maze tasks: reached the goal), None for tasks without success."""
        return None if self.successes is None else float(self.successes.mean())


def rollout(
    env_id: str,
    policy: Policy | None,
    seeds: Sequence[int],
    *,
    record: bool = False,
    transitions: int | None = None,
    on_step: Callable[[int], None] | None = None,
    on_frame: Callable[[int, np.ndarray], None] | None = None,
    frame_every: int = 1,
    start_noise: float = 0.0,
) -> Rollouts:
    """One episode per seed; ``policy=None`` samples uniformly random actions.

    With ``transitions``, a single environment (one seed) plays episode after episode, later resets
    unseeded, until exactly that many transitions; the last episode, cut by the budget, is truncated.
    ``on_step`` gets the running count of transitions; ``on_frame`` (episode index, RGB frame) gets the first
    frame of each episode and one every ``frame_every`` steps. ``start_noise``: ``make_env``'s."""
    if transitions is not None and len(seeds) != 1:
        raise ValueError("a transition budget runs one environment")
    envs = [make_env(env_id, render=on_frame is not None, start_noise=start_noise) for _ in seeds]
    try:
        observations = [env.reset(seed=seed)[0] for env, seed in zip(envs, seeds)]
        for index, (env, seed) in enumerate(zip(envs, seeds)):
            env.action_space.seed(seed)
            if on_frame is not None:
                on_frame(index, env.render())
        traces = [_Trace(obs) for obs in observations]
        finished: list[list[_Trace]] = [[] for _ in seeds]
        live, steps = list(range(len(envs))), 0
        while live:
            if policy is None:
                actions = [envs[i].action_space.sample() for i in live]
            else:
                actions = policy(np.stack([observations[i] for i in live]).astype(np.float32))
            still_live = []
            for i, action in zip(live, actions):
                observations[i], reward, terminated, truncated, info = envs[i].step(action)
                traces[i].add(observations[i], action, reward, record, info)
                steps += 1
                if on_frame is not None and traces[i].length % frame_every == 0:
                    on_frame(i, envs[i].render())
                cut = transitions is not None and steps == transitions
                if terminated or truncated or cut:
                    traces[i].terminated = bool(terminated)
                    finished[i].append(traces[i])
                    if transitions is not None and not cut:
                        observations[i] = envs[i].reset()[0]
                        traces[i] = _Trace(observations[i])
                        still_live.append(i)
                else:
                    still_live.append(i)
                if on_step is not None:
                    on_step(steps)
            live = still_live
    finally:
        for env in envs:
            env.close()
    done = [trace for slot in finished for trace in slot]
    return Rollouts(
        returns=np.array([trace.total for trace in done]),
        episodes=[trace.episode() for trace in done] if record else [],
        terminated=np.array([trace.terminated for trace in done], dtype=bool),
        successes=np.array([bool(trace.success) for trace in done]) if done and all(trace.success is not None for trace in done) else None,
    )


class _Trace:
    """One episode as it is played: its running return and, when recorded, its data."""

    def __init__(self, first_observation: np.ndarray):
        self.total = 0.0
        self.length = 0
        self.terminated = False
        self.success: bool | None = None  # None until the env reports info["success"]
        self.observations, self.actions, self.rewards = [first_observation], [], []

    def add(self, observation, action, reward: float, record: bool, info: dict) -> None:
        if "success" in info:
            self.success = bool(self.success) or bool(info["success"])
        self.total += reward
        self.length += 1
        if record:
            self.observations.append(observation)
            self.actions.append(action)
            self.rewards.append(reward)

    def episode(self) -> Episode:
        return Episode(
            observations=np.asarray(self.observations, dtype=np.float32),
            actions=np.asarray(self.actions, dtype=np.float32),
            rewards=np.asarray(self.rewards, dtype=np.float32),
            terminated=self.terminated,
        )
