"""Stage: state-only expert demonstrations E — recorded from a policy, imported, or the bundled set."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import config as cfg
from ..config import RecordConfig
from ..data import Episode, validate_episodes
from ..envs import EnvInfo, describe_env, require_same_env
from ..errors import LwailError
from ..formats.npz import npz_load_bytes, read_npz, write_npz
from ..formats.sb3_zip import read_sb3_policy
from ..loaders import load_demos, load_policy, policy_fn
from ..mazes import TASKS, cell_center, maze_of
from ..names import closest
from ..planner import MazePlanner
from ..rollout import rollout
from ..video import filmed_rollout
from .shared import default_name, read_external, require_memory

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store


def record_demos(store: Store, *, policy_ref: str, config: RecordConfig, seed: int, name: str | None = None,
                 video_dir: Path | None = None) -> Artifact:
    """State-only episodes of an lwail policy (with ``video_dir``, also an MP4 of each)."""
    policy = store.resolve(policy_ref, "policy")
    info = policy.env
    require_same_env(info, describe_env(info.id), f"policy {policy.ref}")
    return _record(store, info, policy_fn(load_policy(policy)), config, seed, name or default_name(info.id, "demos"),
                   f"policy:{policy.ref}", [policy], video_dir, f"{policy.name}-v{policy.version}")


def import_sb3_demos(store: Store, *, env_id: str, model: Path, config: RecordConfig, seed: int, name: str | None = None,
                     video_dir: Path | None = None) -> Artifact:
    """State-only episodes of a Stable-Baselines3 model.zip's deterministic policy (read without unpickling)."""
    if not model.is_file():
        raise LwailError(f"no such file: {model}")
    info = describe_env(env_id)
    return _record(store, info, read_sb3_policy(model, info), config, seed, name or default_name(env_id, "sb3-demos"),
                   f"sb3:{model.name}", [], video_dir, model.stem)


def _record(store: Store, info: EnvInfo, act, config: RecordConfig, seed: int, name: str, source: str, parents: list,
            video_dir: Path | None, video_prefix: str) -> Artifact:
    seeds = range(seed, seed + config.episodes)
    noise = config.env.start_noise
    if video_dir is None:
        played = rollout(info.id, act, seeds, record=True, start_noise=noise)
    else:
        played, _ = filmed_rollout(info.id, act, seeds, video_dir, video_prefix, record=True, start_noise=noise)
    episodes = [Episode(observations=e.observations, terminated=e.terminated) for e in played.episodes]  # states only
    return _write_demos(store, name, info, episodes, played.returns, {"source": source, **cfg.to_dict(config)}, seed, parents,
                        success_rate=played.success_rate)


def planner_demos(store: Store, *, env_id: str, config: RecordConfig, seed: int, name: str | None = None,
                  video_dir: Path | None = None) -> Artifact:
    """Episodes of the maze planner expert (shortest path over the cells, a PD controller along it: D4RL's maze2d)."""
    maze = maze_of(env_id)
    if maze is None:
        raise LwailError(f"--planner drives the PointMaze tasks ({', '.join(TASKS)}), not {env_id}")
    info = describe_env(env_id)
    cells = maze.cells
    planner = MazePlanner(cells, maze.goal_cell, cell_center(cells, maze.goal_cell))
    return _record(store, info, planner, config, seed, name or default_name(env_id, "planner-demos"), "planner", [], video_dir, "planner")


def import_demos(store: Store, *, env_id: str, name: str | None = None, minari_id: str | None = None, npz: Path | None = None,
                 imitation: Path | None = None) -> Artifact:
    """State-only episodes from a local Minari dataset, a .npz, or trajectories saved by the `imitation` library; the
    name's latest version if it already holds the same (same content hash: ``reused``), else a new version."""
    info = describe_env(env_id)
    if npz is not None:
        require_memory(npz_load_bytes(npz), f"loading {npz}")
    episodes, source, extra = read_external(info, minari_id=minari_id, npz=npz, imitation=imitation)
    returns = extra.pop("returns", None)
    if returns is None and all(e.rewards is not None for e in episodes):
        returns = [e.episode_return for e in episodes]
    name = name or default_name(env_id, "demos")
    returns = np.asarray(returns if returns is not None else [np.nan] * len(episodes), dtype=np.float64)
    return _write_demos(store, name, info, episodes, returns, {"source": source, **extra}, None, [], reuse_same_content=True)


def bundled_demos_path(env_id: str) -> Path:
    folder = resources.files("lwail_cli") / "demos"
    path = folder / f"{env_id}.npz"
    if not path.is_file():
        available = sorted(p.name[:-4] for p in folder.iterdir() if p.name.endswith(".npz"))
        raise LwailError(f"no bundled demos for {env_id}; {closest(env_id, available, 'tasks with bundled demos')}")
    return Path(str(path))


def import_bundled_demos(store: Store, *, env_id: str, name: str | None = None) -> Artifact:
    return import_demos(store, env_id=env_id, name=name or default_name(env_id, "bundled-demos"), npz=bundled_demos_path(env_id))


def holds_bundled_demos(artifact: Artifact) -> bool:
    """Whether a demos artifact holds the episodes lwail bundles for its env today (bundles change when an expert is
    retrained: an import of the old one is not them)."""
    held, held_returns = load_demos(artifact)
    bundled, bundled_returns = read_npz(bundled_demos_path(artifact.env.id))
    return (len(held) == len(bundled) and np.array_equal(held_returns, bundled_returns, equal_nan=True)
            and all(np.array_equal(a.observations, b.observations) for a, b in zip(held, bundled)))


def _write_demos(store: Store, name: str, info: EnvInfo, episodes: list[Episode], returns: np.ndarray, config: dict, seed, parents,
                 reuse_same_content: bool = False, success_rate: float | None = None) -> Artifact:
    validate_episodes(episodes, info, f"demos {name}")
    with store.create("demos", name, env=info, config=config, seed=seed, parents=parents, reuse_same_content=reuse_same_content) as writer:
        write_npz(writer.path("demos.npz"), episodes, returns)
        writer.metrics.update({"episodes": len(episodes), "transitions": int(sum(e.length for e in episodes))})
        if np.all(np.isfinite(returns)):
            writer.metrics.update({"mean_return": float(returns.mean()), "return_std": float(returns.std())})
        if success_rate is not None:
            writer.metrics["success_rate"] = success_rate
        for key in ("ref_min_score", "ref_max_score"):
            if key in config:
                writer.metrics[key] = config[key]
    return writer.artifact
