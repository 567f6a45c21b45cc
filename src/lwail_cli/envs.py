"""Making environments and describing them, so artifacts can refuse data from another task."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import gymnasium as gym
import numpy as np

from . import mazes
from .errors import LwailError

# Ant-v5 observing only its 27 positions and velocities: the same task and reward, without the 78 contact forces that
# Ant-v5 appends to them. The authors' networks saw no more: D4RL's Ant data comes from mujoco-py 2, whose contact
# forces are 0 in every row, so their Ant φ (JackyYang258/LWAIL icvf_model/ant.pt) has those 84 inputs untrained.
ANT_WITHOUT_CONTACT_FORCES = "AntNoContactForces-v5"
if ANT_WITHOUT_CONTACT_FORCES not in gym.registry:
    gym.register(ANT_WITHOUT_CONTACT_FORCES, entry_point="gymnasium.envs.mujoco.ant_v5:AntEnv", max_episode_steps=1000,
                 kwargs={"include_cfrc_ext_in_observation": False})
mazes.register()  # PointMazeUMaze-v0, PointMazeMediumSparse-v0, ...: D4RL's maze2d tasks


@dataclass(frozen=True)
class EnvInfo:
    """What an artifact records about the environment it was made for."""

    id: str
    obs_dim: int
    act_dim: int
    action_low: tuple[float, ...]
    action_high: tuple[float, ...]
    max_episode_steps: int | None

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> EnvInfo:
        """What a manifest recorded; an id that names a module (``module:Env``) would import code, so it is refused."""
        if ":" in str(data.get("id")):
            raise LwailError(f"recorded env id {data['id']!r} names a module to import; lwail makes only registered ids from disk")
        try:
            return cls(
                id=data["id"],
                obs_dim=int(data["obs_dim"]),
                act_dim=int(data["act_dim"]),
                action_low=tuple(data["action_low"]),
                action_high=tuple(data["action_high"]),
                max_episode_steps=data.get("max_episode_steps"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise LwailError(f"the recorded env {data.get('id')!r} is damaged ({type(exc).__name__}: {exc})") from None


class CheckedEnv(gym.Wrapper):
    """An environment checked as it runs, since it may be the user's own: an exception from ``reset`` or ``step``,
    an observation of another shape than its space or not finite, or a reward that is not a finite number, is one
    line naming the env and the step rather than a traceback, or NaN collected and trained on without a word.
    Invisible otherwise: every value passes through unchanged, and the spec is the env's own (Minari records it)."""

    def __init__(self, env: gym.Env, env_id: str):
        super().__init__(env)
        self.env_id = env_id
        self.episode_step = 0  # steps since the last reset, for the message

    @property
    def spec(self):
        return self.env.spec

    def reset(self, **kwargs):
        self.episode_step = 0
        try:
            observation, info = self.env.reset(**kwargs)
        except Exception as exc:  # whatever the env's own code raises
            raise self._fault(f"reset() raised {type(exc).__name__}: {exc}") from None
        self._check_observation(observation)
        return observation, info

    def step(self, action):
        self.episode_step += 1
        try:
            observation, reward, terminated, truncated, info = self.env.step(action)
        except Exception as exc:
            raise self._fault(f"step() raised {type(exc).__name__}: {exc}") from None
        self._check_observation(observation)
        try:
            finite = math.isfinite(float(reward))
        except (TypeError, ValueError):
            finite = False
        if not finite:
            raise self._fault(f"step() returned the reward {reward!r}; rewards must be finite numbers")
        return observation, reward, terminated, truncated, info

    def _check_observation(self, observation) -> None:
        call = "reset()" if self.episode_step == 0 else "step()"
        if np.shape(observation) != self.observation_space.shape:
            raise self._fault(f"{call} returned an observation of shape {np.shape(observation)}; its observation space has {self.observation_space.shape}")
        try:
            finite = bool(np.isfinite(observation).all())
        except TypeError:  # not numbers at all
            finite = False
        if not finite:
            raise self._fault(f"{call} returned an observation that is not all finite numbers (NaN or infinite values)")

    def _fault(self, what: str) -> LwailError:
        where = "at reset" if self.episode_step == 0 else f"at step {self.episode_step} of an episode"
        return LwailError(f"environment {self.env_id} failed {where}: {what}; fix the environment (lwail cannot learn from it)")


def make_env(env_id: str, seed: int | None = None, render: bool = False, start_noise: float = 0.0) -> gym.Env:
    """Create a gymnasium env with a flat Box observation and a bounded Box action, checked as it runs (``CheckedEnv``),
    or explain why not. ``start_noise``: the std of the Gaussian noise on the initial state (the maze tasks only)."""
    if start_noise < 0 or not math.isfinite(start_noise):
        raise LwailError(f"the start-state noise must be a finite std of at least 0, got {start_noise!r}")
    if start_noise > 0 and mazes.maze_of(env_id) is None:
        raise LwailError(f"start-state noise (env.start_noise) is defined for the PointMaze tasks only, not {env_id}")
    kwargs = ({"render_mode": "rgb_array"} if render else {}) | ({"start_noise": start_noise} if start_noise > 0 else {})
    try:
        env = CheckedEnv(gym.make(env_id, **kwargs), env_id)
    except gym.error.Error as exc:
        raise LwailError(f"unknown environment {env_id!r}: {exc}") from None
    except ImportError as exc:
        raise LwailError(f"environment {env_id!r} needs a package that is not installed: {exc}") from None
    except Exception as exc:  # a registered env whose own constructor fails
        raise LwailError(f"environment {env_id!r} failed to start: {type(exc).__name__}: {exc}") from None
    obs_space, act_space = env.observation_space, env.action_space
    if not isinstance(act_space, gym.spaces.Box):
        env.close()
        raise LwailError(
            f"{env_id} has a {type(act_space).__name__} action space; LWAIL's TD3 needs a continuous (Box) one"
        )
    if not (np.all(np.isfinite(act_space.low)) and np.all(np.isfinite(act_space.high))):
        env.close()
        raise LwailError(f"{env_id} has an unbounded action space; TD3 needs finite action bounds")
    if not isinstance(obs_space, gym.spaces.Box) or len(obs_space.shape) != 1:
        env.close()
        raise LwailError(f"{env_id} must have a flat Box observation space, not {obs_space}")
    if seed is not None:
        env.reset(seed=seed)
        env.action_space.seed(seed)
    return env


def env_info(env: gym.Env) -> EnvInfo:
    return EnvInfo(
        id=env.spec.id if env.spec is not None else type(env.unwrapped).__name__,
        obs_dim=int(env.observation_space.shape[0]),
        act_dim=int(env.action_space.shape[0]),
        action_low=tuple(float(v) for v in env.action_space.low),
        action_high=tuple(float(v) for v in env.action_space.high),
        max_episode_steps=env.spec.max_episode_steps if env.spec is not None else None,
    )


def describe_env(env_id: str) -> EnvInfo:
    env = make_env(env_id)
    try:
        return env_info(env)
    finally:
        env.close()


def require_same_env(expected: EnvInfo, found: EnvInfo, what: str) -> None:
    """Refuse an artifact made for another environment or with other observation/action shapes."""
    if found.id != expected.id:
        raise LwailError(f"{what} was made for {found.id}, not {expected.id}")
    if (found.obs_dim, found.act_dim) != (expected.obs_dim, expected.act_dim):
        raise LwailError(
            f"{what} has obs/action dims {found.obs_dim}/{found.act_dim}, "
            f"but {expected.id} has {expected.obs_dim}/{expected.act_dim}"
        )
