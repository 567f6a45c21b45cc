"""The ``.npz`` format of episodes: named arrays (``observations``, ``episode_ends``, optional ``terminations`` and
``returns``), read from their checked headers first and never unpickled (``allow_pickle=False``)."""

from __future__ import annotations

import math
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ..data import Episode
from ..errors import LwailError

# what reading a damaged zip raises: a cut or altered member (BadZipFile, zlib.error), an encrypted one (RuntimeError),
# an unknown compression (NotImplementedError), a bad .npy header or a pickled array (ValueError)
_ZIP_ERRORS = (OSError, ValueError, EOFError, RuntimeError, NotImplementedError, zipfile.BadZipFile, zlib.error)


ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # the earliest time a zip member can carry


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


def load_npz(path: Path, wanted: tuple[str, ...]) -> dict[str, np.ndarray]:
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
    arrays = load_npz(path, ("observations", "episode_ends", "terminations", "returns"))
    for key in ("observations", "episode_ends"):
        if key not in arrays:
            raise LwailError(f"{path} has no {key!r} array (it has: {', '.join(npz_arrays(path)) or 'nothing'})")
    if not is_real(arrays["observations"]):
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
        if not is_real(returns) or returns.shape != (len(episodes),) or not np.all(np.isfinite(returns)):
            raise LwailError(f"{path}: 'returns' must hold one finite number per episode ({len(episodes)}), got {returns.dtype} {returns.shape}")
        returns = returns.astype(np.float64)
    return episodes, returns


def is_real(array: np.ndarray) -> bool:
    """Integers or floats (not bools, complex numbers, strings or objects)."""
    return np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)


def _flags(array: np.ndarray, key: str, count: int, path: Path) -> np.ndarray:
    """One boolean flag per observation (bool, or 0/1): indices or any other encoding is refused, not guessed."""
    if array.shape != (count,) or not (array.dtype == bool or (is_real(array) and np.isin(array, (0, 1)).all())):
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
    """A compressed .npz, as ``np.savez_compressed`` writes it but with a fixed time on every member, so that the
    same episodes make the same bytes (and the same content hash: an import already in the store is found)."""
    arrays = episode_arrays(episodes)
    if returns is not None:
        arrays["returns"] = np.asarray(returns, dtype=np.float64)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for key, array in arrays.items():
            member = zipfile.ZipInfo(f"{key}.npy", date_time=ZIP_TIME)
            member.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(member, "w", force_zip64=True) as handle:
                np.lib.format.write_array(handle, array, allow_pickle=False)
