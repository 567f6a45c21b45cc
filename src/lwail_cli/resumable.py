"""What a resumable run's state is, captured in one dict and restored from it.

A run names its parts once (networks with their optimizers, a replay buffer, a reward model, a numpy generator,
the environment), each with ``state_dict``/``load_state_dict``; ``capture`` adds torch's global generators and the
run's plain values (its step, logs, wall time), ``restore`` reads the same table back, so what a checkpoint saves
and what a resume restores cannot drift apart. Tensors and plain data only (checkpoints load with
``weights_only=True``); storing the dict is the caller's part (``runs.py``).
"""

from __future__ import annotations

import time
from typing import Protocol

import gymnasium as gym
import numpy as np
import torch


class Part(Protocol):
    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


def capture(parts: dict[str, Part], **values) -> dict:
    """Every part's state, the plain ``values`` and torch's random generators (CPU, and CUDA where there is one)."""
    return {name: part.state_dict() for name, part in parts.items()} | values | {
        "torch_rng": torch.get_rng_state(),
        "cuda_rng": torch.cuda.get_rng_state_all() if torch.cuda.is_available() else None,
    }


def restore(state: dict, parts: dict[str, Part]) -> None:
    """Load a ``capture``d state into the same parts; the caller reads its plain values back itself."""
    for name, part in parts.items():
        part.load_state_dict(state[name])
    torch.set_rng_state(state["torch_rng"])
    if state.get("cuda_rng") is not None:
        torch.cuda.set_rng_state_all(state["cuda_rng"])


def checkpoint_due(step: int, every: int, last: int) -> bool:
    """A checkpoint every ``every`` steps, none at the last step (the run's artifact holds the result)."""
    return step % every == 0 and step < last


class Stopwatch:
    """A run's wall time, counted on from what a resumed run had already spent."""

    def __init__(self, spent: float = 0.0):
        self._started = time.perf_counter() - spent

    def elapsed(self) -> float:
        return time.perf_counter() - self._started


class NumpyGenerator:
    """A numpy generator as a part (e.g. TD3's exploration noise)."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def state_dict(self) -> dict:
        return self.rng.bit_generator.state

    def load_state_dict(self, state: dict) -> None:
        self.rng.bit_generator.state = state


class EnvironmentState:
    """An environment mid-episode as a part: its generators, time limit and (MuJoCo) full integration state."""

    def __init__(self, env: gym.Env):
        self.env = env

    def state_dict(self) -> dict:
        env = self.env
        state = {
            "np_random": env.unwrapped.np_random.bit_generator.state,
            "action_space": env.action_space.np_random.bit_generator.state,
            "elapsed_steps": getattr(_time_limit(env), "_elapsed_steps", None),
        }
        if hasattr(env.unwrapped, "model") and hasattr(env.unwrapped, "data"):
            import mujoco

            model, data = env.unwrapped.model, env.unwrapped.data
            physics = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION))
            mujoco.mj_getState(model, data, physics, mujoco.mjtState.mjSTATE_INTEGRATION)
            state["mujoco"] = torch.from_numpy(physics)  # tensors only: checkpoints load with weights_only=True
        return state

    def load_state_dict(self, state: dict) -> None:
        env = self.env
        env.unwrapped.np_random.bit_generator.state = state["np_random"]
        env.action_space.np_random.bit_generator.state = state["action_space"]
        if "mujoco" in state:  # warm-start and actuator state included, so the rollout continues bit for bit
            import mujoco

            model, data = env.unwrapped.model, env.unwrapped.data
            mujoco.mj_setState(model, data, state["mujoco"].numpy(), mujoco.mjtState.mjSTATE_INTEGRATION)
            mujoco.mj_forward(model, data)
        limit = _time_limit(env)
        if limit is not None and state["elapsed_steps"] is not None:
            limit._elapsed_steps = state["elapsed_steps"]


def _time_limit(env: gym.Env) -> gym.wrappers.TimeLimit | None:
    while isinstance(env, gym.Wrapper):
        if isinstance(env, gym.wrappers.TimeLimit):
            return env
        env = env.env
    return None
