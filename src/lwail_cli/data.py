"""State-only data: episodes of observations with their boundaries, collected, imported or stored.

An episode holds ``T+1`` observations and ``T`` transitions. Pairs ``(s_t, s_{t+1})`` are formed
inside an episode, never across a boundary. Terminations and truncations are kept apart because
later stages bootstrap through a truncation but not through a termination.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from .envs import EnvInfo
from .errors import LwailError


@dataclass
class Episode:
    observations: np.ndarray  # (T+1, obs_dim)
    actions: np.ndarray | None = None  # (T, act_dim)
    rewards: np.ndarray | None = None  # (T,)
    terminated: bool = False  # the last observation is terminal (no bootstrapping past it)

    @property
    def length(self) -> int:
        return len(self.observations) - 1

    @property
    def episode_return(self) -> float:
        return float(self.rewards.sum()) if self.rewards is not None else float("nan")


@dataclass
class FlatEpisodes:
    """Episodes concatenated for fast index sampling."""

    observations: np.ndarray  # (N, obs_dim) float32, every episode's T+1 observations back to back
    episode_end: np.ndarray  # (N,) index of the last observation of the episode each row belongs to
    episode_start: np.ndarray  # (N,)
    has_successor: np.ndarray  # (N,) bool, False on each episode's last observation


def flatten(episodes: list[Episode]) -> FlatEpisodes:
    lengths = np.array([len(e.observations) for e in episodes])
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    ends = starts + lengths - 1
    observations = np.concatenate([e.observations for e in episodes]).astype(np.float32)
    has_successor = np.ones(len(observations), dtype=bool)
    has_successor[ends] = False
    return FlatEpisodes(
        observations=observations,
        episode_end=np.repeat(ends, lengths),
        episode_start=np.repeat(starts, lengths),
        has_successor=has_successor,
    )


def transition_pairs(episodes: list[Episode]) -> tuple[np.ndarray, np.ndarray]:
    """All ``(s, s')`` pairs inside episodes, as float32 arrays."""
    states = np.concatenate([e.observations[:-1] for e in episodes]).astype(np.float32)
    successors = np.concatenate([e.observations[1:] for e in episodes]).astype(np.float32)
    return states, successors


def validate_episodes(episodes: list[Episode], env: EnvInfo, source: str) -> None:
    if not episodes:
        raise LwailError(f"{source} holds no episodes")
    for episode in episodes:
        obs = episode.observations
        if obs.ndim != 2 or obs.shape[1] != env.obs_dim:
            raise LwailError(
                f"{source} has observations of shape {obs.shape[1:] if obs.ndim == 2 else obs.shape}, "
                f"but {env.id} observations have {env.obs_dim} dims"
            )
        if episode.actions is not None and episode.actions.shape[-1] != env.act_dim:
            raise LwailError(f"{source} has {episode.actions.shape[-1]}-dim actions, but {env.id} has {env.act_dim}")
        if not np.all(np.isfinite(obs)):
            raise LwailError(f"{source} contains NaN or infinite observations")
    if sum(e.length for e in episodes) == 0:
        raise LwailError(f"{source} holds no transitions (every episode has a single observation)")


# ------------------------------------------------------------------------------ Minari format
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


# ------------------------------------------------------------------------------ .npz files
# what reading a damaged zip raises: a cut or altered member (BadZipFile, zlib.error), an encrypted one (RuntimeError),
# an unknown compression (NotImplementedError), a bad .npy header or a pickled array (ValueError)
_ZIP_ERRORS = (OSError, ValueError, EOFError, RuntimeError, NotImplementedError, zipfile.BadZipFile, zlib.error)


def npz_arrays(path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """The arrays a .npz declares (name: shape, dtype), read from their headers alone, so that nothing is allocated
    before the file is known to be sound: a zip of .npy members, each storing exactly the bytes its shape declares
    (a damaged or forged header, say a shape of 14 TiB, is refused here rather than allocated). Object arrays
    (pickles) are listed but never loaded."""
    if not path.is_file():
        raise LwailError(f"no such file: {path}" if not path.exists() else f"{path} is not a regular file (a folder, FIFO or device?)")
    if not zipfile.is_zipfile(path):
        with open(path, "rb") as handle:
            single = handle.read(6) == b"\x93NUMPY"
        raise LwailError(f"{path} holds a single array (.npy), not a .npz of named arrays ('observations', 'episode_ends', ...)" if single
                         else f"cannot read {path} as a .npz file: it is not a zip archive (empty, cut short, or another format)")
    declared = {}
    try:
        with zipfile.ZipFile(path) as archive:
            for member in archive.infolist():
                if not member.filename.endswith(".npy"):
                    raise LwailError(f"{path} is a zip but not a .npz: its member {member.filename!r} is no .npy array")
                with archive.open(member) as handle:
                    version = np.lib.format.read_magic(handle)
                    header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
                    shape, _, dtype = header(handle)
                    stored = member.file_size - handle.tell()
                name = member.filename.removesuffix(".npy")
                if not dtype.hasobject and (math.prod(shape) * dtype.itemsize != stored or min(shape, default=0) < 0):
                    raise LwailError(f"{path}: {name!r} declares a {dtype} array of shape {shape} but stores {stored} bytes: "
                                     "the file is damaged or was altered")
                declared[name] = (shape, dtype)
    except _ZIP_ERRORS as exc:
        raise LwailError(f"cannot read {path} as a .npz file ({type(exc).__name__}: {exc})") from None
    return declared


def npz_load_bytes(path: Path) -> int:
    """Memory that importing a .npz takes, from its checked headers (``npz_arrays``): its numeric arrays three times
    over (as read, as float32 episodes, and copied into the artifact's format)."""
    return 3 * sum(math.prod(shape) * dtype.itemsize for shape, dtype in npz_arrays(path).values() if not dtype.hasobject)


def _load_npz(path: Path, wanted: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The ``wanted`` arrays a .npz holds (others, pickles included, are never read), each of real numbers or bools."""
    declared = npz_arrays(path)
    for name in set(wanted) & set(declared):
        dtype = declared[name][1]
        if dtype.hasobject or dtype.kind not in "biufc":
            raise LwailError(f"{path}: {name!r} must hold real numbers or bool flags, not {dtype} (lwail never unpickles)")
    try:
        with np.load(path, allow_pickle=False) as archive:
            return {key: archive[key] for key in wanted if key in declared}
    except _ZIP_ERRORS as exc:  # sound headers, damaged data (a CRC error)
        raise LwailError(f"cannot read {path} as a .npz file ({type(exc).__name__}: {exc})") from None


def read_npz(path: Path) -> tuple[list[Episode], np.ndarray | None]:
    """Episodes from a ``.npz``: ``observations`` (N, obs_dim) and ``episode_ends`` (N,) bool marking
    each episode's last observation; optional ``terminations`` (N,) bool on those last observations
    and ``returns`` (one per episode). Returns the episodes and the returns (or None)."""
    arrays = _load_npz(path, ("observations", "episode_ends", "terminations", "returns"))
    for key in ("observations", "episode_ends"):
        if key not in arrays:
            raise LwailError(f"{path} has no {key!r} array (it has: {', '.join(npz_arrays(path)) or 'nothing'})")
    if not _is_real(arrays["observations"]):
        raise LwailError(f"{path}: 'observations' must hold real numbers, not {arrays['observations'].dtype}")
    observations = np.asarray(arrays["observations"], dtype=np.float32)
    if observations.ndim != 2 or len(observations) == 0:
        raise LwailError(f"{path}: 'observations' must be a non-empty (N, obs_dim) array, got {observations.shape}")
    ends = _flags(arrays["episode_ends"], "episode_ends", len(observations), path)
    if not ends[-1]:
        raise LwailError(f"{path}: 'episode_ends' must mark the last observation as an episode end")
    terminations = _flags(arrays["terminations"], "terminations", len(observations), path) if "terminations" in arrays else np.zeros_like(ends)
    cut_points = np.flatnonzero(ends) + 1
    episodes = [
        Episode(observations=chunk, terminated=bool(term[-1]))
        for chunk, term in zip(np.split(observations, cut_points[:-1]), np.split(terminations, cut_points[:-1]))
    ]
    returns = arrays.get("returns")
    if returns is not None:
        if not _is_real(returns) or returns.shape != (len(episodes),) or not np.all(np.isfinite(returns)):
            raise LwailError(f"{path}: 'returns' must hold one finite number per episode ({len(episodes)}), got {returns.dtype} {returns.shape}")
        returns = returns.astype(np.float64)
    return episodes, returns


# ------------------------------------------------------------------------------ the `imitation` library's trajectories
def read_imitation(path: Path) -> list[Episode]:
    """Episodes saved by the ``imitation`` library (``imitation.data.serialize.save``): its HuggingFace-datasets
    folder (Arrow files), or the older ``.npz``. Only ``obs``, ``terminal`` and ``rews`` are read: ``infos`` are
    jsonpickle strings, whose decoding can run code, and pickled trajectory files are refused."""
    if path.is_dir():
        observations, terminal, rewards = _imitation_folder(path)
    elif path.is_file() and zipfile.is_zipfile(path):  # is_file first: opening a FIFO would wait for a writer forever
        observations, terminal, rewards = _imitation_npz(path)
    else:
        raise LwailError(f"{path} is neither a folder written by imitation.data.serialize.save nor imitation's older .npz "
                         "(pickled trajectories are never read: unpickling can run code; load them with imitation and save them again)")
    episodes = []
    for index, obs in enumerate(observations):
        where = f"{path} trajectory {index}"
        if obs.ndim != 2 or len(obs) == 0 or not _is_real(obs):
            raise LwailError(f"{where}: 'obs' must be a (T+1, obs_dim) array of real numbers (flat observations), got {obs.dtype} {obs.shape}")
        steps_rewards = None
        if rewards is not None:
            steps_rewards = rewards[index]
            if steps_rewards.shape != (len(obs) - 1,) or not _is_real(steps_rewards) or not np.all(np.isfinite(steps_rewards)):
                raise LwailError(f"{where}: 'rews' must hold one finite number per transition ({len(obs) - 1}), got {steps_rewards.shape}")
            steps_rewards = steps_rewards.astype(np.float32)
        episodes.append(Episode(observations=obs.astype(np.float32), rewards=steps_rewards, terminated=bool(terminal[index])))
    return episodes


def _imitation_folder(path: Path) -> tuple[list[np.ndarray], list, list[np.ndarray] | None]:
    try:
        import pyarrow as pa
        import pyarrow.ipc
    except ImportError:
        raise LwailError('reading imitation\'s trajectory folders needs pyarrow: pip install "lwail[imitation]"') from None
    if not (path / "state.json").is_file():
        raise LwailError(f"{path} has no readable state.json naming its data files (as datasets' save_to_disk writes)")
    try:
        files = [entry["filename"] for entry in json.loads((path / "state.json").read_text())["_data_files"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise LwailError(f"{path} has no readable state.json naming its data files (as datasets' save_to_disk writes): {exc}") from None
    if not files or not all(isinstance(name, str) and name not in ("", ".", "..") and Path(name).name == name and (path / name).is_file()
                            for name in files):
        raise LwailError(f"{path}/state.json must name its data files inside the folder, got {files!r}")
    try:
        table = pa.concat_tables([pa.ipc.open_stream(pa.memory_map(str(path / name))).read_all() for name in files])
    except (OSError, pa.ArrowException) as exc:
        raise LwailError(f"{path} has an unreadable data file ({type(exc).__name__}: {exc})") from None
    for column in ("obs", "terminal"):
        if column not in table.column_names:
            raise LwailError(f"{path} has no {column!r} column (it has: {', '.join(table.column_names)}); is it imitation's trajectories?")
    if not pa.types.is_boolean(table.schema.field("terminal").type):
        raise LwailError(f"{path}: 'terminal' must be one bool per trajectory, got {table.schema.field('terminal').type}")
    try:
        observations = [np.asarray(rows) for rows in table.column("obs").to_pylist()]
        rewards = [np.asarray(rows) for rows in table.column("rews").to_pylist()] if "rews" in table.column_names else None
    except ValueError as exc:  # ragged rows
        raise LwailError(f"{path}: every trajectory's 'obs' must be a (T+1, obs_dim) table and its 'rews' a list of numbers ({exc})") from None
    return observations, table.column("terminal").to_pylist(), rewards


def _imitation_npz(path: Path) -> tuple[list[np.ndarray], np.ndarray, list[np.ndarray] | None]:
    """imitation's older format: every trajectory's obs back to back, ``indices`` the cut points of the
    transitions (one fewer than the trajectories), ``terminal`` one flag per trajectory."""
    archive = _load_npz(path, ("obs", "acts", "indices", "terminal", "rews"))
    missing = [key for key in ("obs", "acts", "indices", "terminal") if key not in archive]
    if missing:
        raise LwailError(f"{path} has no {', '.join(map(repr, missing))} (it has: {', '.join(npz_arrays(path))}); is it imitation's trajectories?")
    obs, indices, terminal = archive["obs"], archive["indices"], archive["terminal"]
    transitions = len(archive["acts"])  # the actions themselves are not kept: they only check the cut points
    rews = archive.get("rews")
    count = len(indices) + 1
    if (obs.ndim != 2 or indices.ndim != 1 or not np.issubdtype(indices.dtype, np.integer) or np.any(np.diff(indices) < 0)
            or np.any(indices < 0) or np.any(indices > transitions) or terminal.shape != (count,) or terminal.dtype != bool
            or len(obs) != transitions + count or rews is not None and rews.shape != (transitions,)):
        raise LwailError(f"{path}: expected (N, obs_dim) 'obs' holding T+1 rows per trajectory, increasing 'indices' cutting the "
                         f"{transitions} transitions, 'terminal' one bool per trajectory and 'rews' one number per transition; got obs "
                         f"{obs.shape}, indices {indices.dtype} {indices.shape}, terminal {terminal.dtype} {terminal.shape}")
    rewards = None if rews is None else np.split(rews, indices)
    return np.split(obs, indices + np.arange(1, count)), terminal, rewards


def _is_real(array: np.ndarray) -> bool:
    return np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)


def _flags(array: np.ndarray, key: str, count: int, path: Path) -> np.ndarray:
    """One boolean flag per observation (bool, or 0/1): indices or any other encoding is refused, not guessed."""
    if array.shape != (count,) or not (array.dtype == bool or (_is_real(array) and np.isin(array, (0, 1)).all())):
        raise LwailError(f"{path}: {key!r} must be one flag (bool or 0/1) per observation ({count}), got {array.dtype} {array.shape}")
    return array.astype(bool)


def episode_arrays(episodes: list[Episode]) -> dict[str, np.ndarray]:
    """Episodes as the flat arrays of the .npz format: observations, episode_ends, terminations."""
    observations = np.concatenate([e.observations for e in episodes]).astype(np.float32)
    ends = np.zeros(len(observations), dtype=bool)
    terminations = np.zeros(len(observations), dtype=bool)
    last = np.cumsum([len(e.observations) for e in episodes]) - 1
    ends[last] = True
    terminations[last] = [e.terminated for e in episodes]
    return {"observations": observations, "episode_ends": ends, "terminations": terminations}


def write_npz(path: Path, episodes: list[Episode], returns: np.ndarray | None = None) -> None:
    arrays = episode_arrays(episodes)
    if returns is not None:
        arrays["returns"] = np.asarray(returns, dtype=np.float64)
    with open(path, "wb") as handle:
        np.savez_compressed(handle, **arrays)
