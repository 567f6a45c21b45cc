"""The run area, ``<store>/.runs/``: what runs in progress keep outside the versioned store.

``.runs/<kind>/<name>/`` holds a run's lock, its checkpoint, the CSVs it logs while it trains and a pause asked of it
(a killed or paused run's stay for ``--resume``; a finished run's artifact is a new version of the store, and its folder goes).
``.runs/sweep/<sweep>/`` holds a sweep's ledger of finished stages and what each of its runs is doing now. Every
file here is replaced whole (``_replacing``), so a kill or a reader never finds half of one.
"""

from __future__ import annotations

import contextlib
import csv
import itertools
import os
import re
import shutil
import socket
from pathlib import Path
from typing import IO, Iterator

from .errors import LwailError
from .names import check_name, parse_ref

PAUSE_REQUEST = "pause"  # in a run's folder: `lwail pause` asks its process to checkpoint and stop


class RunArea:
    def __init__(self, store_root: Path):
        self.store_root = store_root
        self.root = store_root / ".runs"

    def _folder(self, kind: str, name: str) -> Path:
        check_name(name)
        return self.root / kind / name

    def _checkpoint_path(self, kind: str, name: str) -> Path:
        return self._folder(kind, name) / "checkpoint.pt"

    # ---------------------------------------------------------------- one run per name, resumed from its checkpoint
    @contextlib.contextmanager
    def claim_run(self, kind: str, name: str, *, resume: bool) -> Iterator[None]:
        """One run per name at a time, and a fresh run never overwrites the checkpoint a killed run left.

        A refused command leaves the store as it was: the claim's own checks come before its lock is written, and a
        run refused inside the claim (its caller checks the checkpoint there) before it wrote anything gets its
        folder back as it was found, a killed process's lock included."""
        folder = self._folder(kind, name)
        what = f"{kind}/{name}"
        if not resume and (folder / "checkpoint.pt").exists():
            raise LwailError(
                f"a killed run of {what} left a checkpoint: add --resume to continue it, "
                f"choose another --name, or delete {folder} to start over"
            )
        lock = folder / "lock"
        stale = _stale_lock(lock, what)
        created = list(itertools.takewhile(lambda directory: not directory.exists(), (folder, *folder.parents)))
        folder.mkdir(parents=True, exist_ok=True)
        if stale is not None:
            lock.unlink(missing_ok=True)  # left by a killed process: take it over
        owner = f"{socket.gethostname()} {os.getpid()}".encode()
        try:
            with open(lock, "xb") as handle:
                handle.write(owner)
        except FileExistsError:
            raise LwailError(f"{what}: another process took the run's lock {lock} at the same time") from None
        found = _folder_state(folder)
        try:
            yield
        except BaseException:
            if _folder_state(folder) == found:  # refused before writing anything: no trace of the attempt
                with contextlib.suppress(OSError):  # best effort: the refusal itself is what must reach the user
                    lock.unlink()
                    if stale is not None:
                        lock.write_bytes(stale)
                for directory in created:  # deepest first; one another run has filled since stays
                    with contextlib.suppress(OSError):
                        directory.rmdir()
            raise
        finally:
            if _read_small(lock) == owner:
                lock.unlink()

    def save_checkpoint(self, kind: str, name: str, state: dict) -> Path:
        """Replace the run's checkpoint atomically (a kill mid-write keeps the previous one)."""
        import torch

        path = self._checkpoint_path(kind, name)
        with _replacing(path, binary=True) as handle:
            torch.save(state, handle)
        return path

    def load_checkpoint(self, kind: str, name: str) -> dict:
        import torch

        path = self._checkpoint_path(kind, name)
        if not path.is_file():
            raise LwailError(f"--resume: no checkpoint for {kind}/{name} in store {self.store_root}")
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)  # tensors and plain data only: no code runs
        except Exception as exc:  # foreign bytes fail torch's reader in many ways (text: KeyError, a cut file: OSError)
            problem = type(exc).__name__
        else:
            if isinstance(state, dict) and isinstance(state.get("record"), dict):  # what made the run: every checkpoint has it
                return state
            problem = "not a checkpoint of an lwail run"
        raise LwailError(f"--resume: the checkpoint {path} is corrupt ({problem}); delete {path.parent} to start over, "
                         "or choose another --name")

    def has_checkpoint(self, kind: str, name: str) -> bool:
        return self._checkpoint_path(kind, name).is_file()

    def clear_checkpoint(self, kind: str, name: str) -> None:
        shutil.rmtree(self._folder(kind, name), ignore_errors=True)

    # ---------------------------------------------------------------- a pause asked of a run in progress
    def request_pause(self, name: str, *, missing_ok: bool = False) -> list[str]:
        """Ask the process training a run named ``name`` (an `imitate`, `expert train` or `pretrain-icvf` run: its
        lock's holder, alive) to checkpoint and stop (`lwail pause`); returns the kinds of the runs asked. None in
        progress is refused unless ``missing_ok``."""
        check_name(name)
        kinds = sorted(folder.parent.name for folder in self.root.glob(f"*/{name}") if _in_progress(folder))
        if not kinds and not missing_ok:
            raise LwailError(f"no run named {name} is in progress in this store (finished, killed or never started): nothing to pause")
        for kind in kinds:
            with contextlib.suppress(FileNotFoundError):  # it finished meanwhile, its folder gone: nothing left to pause
                (self._folder(kind, name) / PAUSE_REQUEST).touch()
        return kinds

    def take_pause_request(self, kind: str, name: str) -> bool:
        """Whether a pause was asked of ``kind/name``; the request is taken (a resumed run does not stop at once)."""
        request = self._folder(kind, name) / PAUSE_REQUEST
        if not request.exists():
            return False
        request.unlink(missing_ok=True)
        return True

    def run_log(self, kind: str, name: str, filename: str) -> Path:
        """A CSV a run in progress (or a killed one) keeps beside its checkpoint."""
        return self._folder(kind, name) / filename

    def write_run_log(self, kind: str, name: str, filename: str, rows: list[dict]) -> None:
        """Rewrite a run's CSV atomically, so a reader never sees half a row (columns: every key, first seen first)."""
        columns = list(dict.fromkeys(key for row in rows for key in row))
        with _replacing(self.run_log(kind, name, filename)) as handle:
            writer = csv.DictWriter(handle, fieldnames=columns)
            writer.writeheader()
            writer.writerows(rows)

    # ---------------------------------------------------------------- a sweep's ledger of finished stages
    def _ledger_entry(self, sweep: str, key: str) -> Path:
        check_name(sweep)
        if not re.fullmatch(r"[a-z0-9-]{1,100}", key):
            raise ValueError(f"bad ledger key {key!r}")
        return self.root / "sweep" / sweep / f"{key}.ref"

    def finished_stage_ref(self, sweep: str, key: str, kind: str, name: str) -> str | None:
        """The ref ``kind/name@vN`` a sweep recorded for a stage fingerprint; None if there is none or the entry names
        anything else (the store then checks that the version is still there and intact)."""
        recorded = (_read_small(self._ledger_entry(sweep, key)) or b"").decode(errors="replace").strip()
        parsed = parse_ref(recorded)
        if parsed is None or parsed[:2] != (kind, name) or parsed[2] is None:
            return None
        return recorded

    def record_finished_stage(self, sweep: str, key: str, ref: str) -> None:
        with _replacing(self._ledger_entry(sweep, key)) as handle:
            handle.write(ref)

    def _status_path(self, sweep: str, run: str) -> Path:
        check_name(sweep)
        check_name(run)
        return self.root / "sweep" / sweep / f"{run}.status"

    def set_sweep_status(self, sweep: str, run: str, line: str) -> None:
        """What a sweep's run (named by its policy) is doing now, for the sweep's driver to show."""
        with _replacing(self._status_path(sweep, run)) as handle:
            handle.write(line)

    def sweep_status(self, sweep: str, run: str) -> str | None:
        line = _read_small(self._status_path(sweep, run))
        return None if line is None else line.decode(errors="replace")

    def clear_sweep_status(self, sweep: str, run: str) -> None:
        self._status_path(sweep, run).unlink(missing_ok=True)


def _in_progress(folder: Path) -> bool:
    """Whether a live process holds the run folder's lock (one of another host counts: it cannot be checked from here)."""
    holder = _holder(_read_small(folder / "lock"))
    return holder is not None and not abandoned_by(*holder)


def abandoned_by(host: str, pid: int) -> bool:
    """Whether what process ``pid`` of ``host`` left (a lock, a half-written version) is abandoned: that process ran
    on this host and is gone. One of another host is never taken over: its liveness cannot be checked from here."""
    return host == socket.gethostname() and not _alive(pid)


def _stale_lock(lock: Path, what: str) -> bytes | None:
    """The bytes of a run's lock that a killed process of this host left (to take over), None without a lock. A lock
    of a live process, or of another host, is refused; so is a damaged one (not 'host pid'): whether a process still
    trains the run is the user's call."""
    if not os.path.lexists(lock):
        return None
    held = _read_small(lock)
    holder = _holder(held)
    if holder is None:
        raise LwailError(f"the lock {lock} of {what} is damaged (not 'host pid'); if no process is training {what}, delete it")
    host, pid = holder
    if abandoned_by(host, pid):
        return held
    raise LwailError(f"{what} is being trained by process {pid} on {host}; wait for it, or choose another --name "
                     f"(if that process is gone, delete {lock})")


def _holder(held: bytes | None) -> tuple[str, int] | None:
    """The host and pid a lock's bytes name ('host pid'); None for no lock or a damaged one."""
    found = re.fullmatch(rb"(\S+) ([1-9][0-9]*)", held or b"")
    return None if found is None else (found[1].decode(errors="replace"), int(found[2]))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # no such process (a pid past the C range cannot be one)
        return False
    except PermissionError:  # someone else's process
        return True
    return True


@contextlib.contextmanager
def _replacing(path: Path, *, binary: bool = False) -> Iterator[IO]:
    """A handle whose contents replace ``path`` whole once the block ends: written beside it, synced, then renamed
    over it, so a kill mid-write keeps the previous file. A folder found in its place (damage) is replaced too."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    partial = path.with_suffix(".partial")
    with open(partial, "wb") if binary else open(partial, "w", newline="") as handle:
        yield handle
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(partial, path)


def _read_small(path: Path, limit: int = 4096) -> bytes | None:
    """The first bytes of a small regular file; None for anything else (missing, a folder, a link, a FIFO or a
    device, which could block or never end), so a planted run file can neither hang nor flood a reader."""
    try:
        if path.is_symlink() or not path.is_file():
            return None
        with open(path, "rb") as handle:
            return handle.read(limit)
    except OSError:
        return None


def _folder_state(folder: Path) -> dict[str, tuple[int, int]]:
    """Size and modification time of each entry of a run folder but its lock ({} without the folder)."""
    try:
        entries = list(os.scandir(folder))
    except FileNotFoundError:
        return {}
    return {entry.name: (entry.stat(follow_symlinks=False).st_size, entry.stat(follow_symlinks=False).st_mtime_ns)
            for entry in entries if entry.name != "lock"}
