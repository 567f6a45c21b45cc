"""Minari's on-disk format (``metadata.json`` and ``main_data.hdf5``): read with h5py alone, written with Minari's storage.

Datasets are read from the local Minari store or from a dataset artifact, never downloaded, and never through
``minari.MinariDataset`` (see ``read_minari_directory``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import gymnasium as gym
import numpy as np

from ..data import Episode
from ..errors import LwailError


def write_minari(episodes: list[Episode], directory: Path, dataset_id: str, env: gym.Env, source: str, description: str) -> None:
    """Write episodes in Minari's on-disk format so ``minari.MinariDataset(directory)`` loads them."""
    from minari import __version__ as minari_version
    from minari.data_collector import EpisodeBuffer
    from minari.dataset.minari_storage import MinariStorage

    storage = MinariStorage.new(
        directory,
        observation_space=env.observation_space,
        action_space=env.action_space,
        env_spec=env.spec,
        data_format="hdf5",
    )
    storage.update_metadata(
        {
            "dataset_id": dataset_id,
            "minari_version": minari_version,
            "algorithm_name": source,
            "description": description,
            "author": {"lwail"},
        }
    )
    buffers = []
    for index, episode in enumerate(episodes):
        terminations = np.zeros(episode.length, dtype=bool)
        truncations = np.zeros(episode.length, dtype=bool)
        if episode.terminated:
            terminations[-1] = True
        else:
            truncations[-1] = True
        buffers.append(
            EpisodeBuffer(
                id=index,
                observations=episode.observations.astype(env.observation_space.dtype),
                actions=episode.actions,
                rewards=list(episode.rewards),
                terminations=list(terminations),
                truncations=list(truncations),
            )
        )
    storage.update_episodes(buffers)


def read_minari_directory(directory: Path, source: str) -> tuple[list[Episode], dict]:
    """Episodes and metadata of a dataset in Minari's hdf5 format, read with h5py alone.

    ``minari.MinariDataset`` is never opened: for a dataset without stored spaces it rebuilds the env from the
    metadata's ``env_spec`` (``gym.make`` of any entry point), so a shared dataset could run code."""
    import h5py

    try:
        metadata = json.loads((directory / "metadata.json").read_text())
    except (OSError, ValueError) as exc:
        raise LwailError(f"{source} has no readable metadata.json: {exc}") from None
    if not isinstance(metadata, dict) or metadata.get("data_format", "hdf5") != "hdf5":
        raise LwailError(f"{source} is not a Minari dataset in hdf5 format")
    from minari import __version__ as minari_version
    from minari import supported_dataset_versions

    version = metadata.get("minari_version")
    if not isinstance(version, str) or version not in supported_dataset_versions:
        raise LwailError(f"{source} was written by Minari {version!r}, a format the installed Minari {minari_version} does not read "
                         f"(it reads {', '.join(sorted(supported_dataset_versions))}); upgrade minari, or import the data as a .npz")
    if not (directory / "main_data.hdf5").is_file():  # not a FIFO either: HDF5 would wait on it for a writer
        raise LwailError(f"{source} has no main_data.hdf5 file")
    try:
        with h5py.File(directory / "main_data.hdf5", "r") as data:
            names = sorted((key for key in data if key.startswith("episode_")), key=lambda key: int(key[len("episode_"):]))
            episodes = [_minari_episode(data[key], f"{source} {key}") for key in names]
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise LwailError(f"{source} has a damaged main_data.hdf5 ({type(exc).__name__}: {exc})") from None
    return episodes, metadata


def _minari_episode(group, source: str) -> Episode:
    import h5py

    if not isinstance(group.get("observations"), h5py.Dataset):
        raise LwailError(f"{source} has no flat observations (dict observations?); lwail needs flat Box observations")
    observations = np.asarray(group["observations"][()])
    if observations.ndim != 2 or not np.issubdtype(observations.dtype, np.number) or np.iscomplexobj(observations):
        raise LwailError(f"{source} has observations of shape {observations.shape} and dtype {observations.dtype}; expected (T+1, d) real numbers")
    steps = observations.shape[0] - 1
    arrays = {key: np.asarray(group[key][()]) for key in ("actions", "rewards", "terminations")}
    if any(len(array) != steps for array in arrays.values()):
        raise LwailError(f"{source} has {steps + 1} observations but not {steps} actions, rewards and terminations")
    return Episode(
        observations=observations.astype(np.float32),
        actions=arrays["actions"].astype(np.float32),
        rewards=arrays["rewards"].astype(np.float32),
        terminated=bool(arrays["terminations"][-1]) if steps else False,
    )


def load_local_minari(dataset_id: str) -> tuple[list[Episode], dict]:
    """A dataset from the local Minari store (episodes, metadata); never downloads, never reads outside the store."""
    from minari.storage import get_dataset_path

    if Path(dataset_id).is_absolute() or ".." in Path(dataset_id).parts:
        raise LwailError(f"Minari dataset id {dataset_id!r} must name a dataset inside the local Minari store")

    path = Path(get_dataset_path(dataset_id))
    if not (path / "data" / "metadata.json").is_file():
        root = os.environ.get("MINARI_DATASETS_PATH", "~/.minari/datasets")
        raise LwailError(
            f"Minari dataset {dataset_id!r} is not in the local Minari store ({root}); "
            "lwail never downloads: fetch it with `minari download` on a connected machine, or pass --from-file"
        )
    return read_minari_directory(path / "data", f"Minari dataset {dataset_id!r}")
