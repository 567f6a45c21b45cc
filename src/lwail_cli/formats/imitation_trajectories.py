"""Trajectories saved by the ``imitation`` library: its HuggingFace-datasets folder (Arrow files), or its older
``.npz``; only the state-only parts are read."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from ..data import Episode
from ..errors import LwailError
from .npz import is_real, load_npz, npz_arrays


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
        if obs.ndim != 2 or len(obs) == 0 or not is_real(obs):
            raise LwailError(f"{where}: 'obs' must be a (T+1, obs_dim) array of real numbers (flat observations), got {obs.dtype} {obs.shape}")
        steps_rewards = None
        if rewards is not None:
            steps_rewards = rewards[index]
            if steps_rewards.shape != (len(obs) - 1,) or not is_real(steps_rewards) or not np.all(np.isfinite(steps_rewards)):
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
    archive = load_npz(path, ("obs", "acts", "indices", "terminal", "rews"))
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
