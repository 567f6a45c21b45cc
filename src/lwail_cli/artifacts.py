"""The artifact store: the only code that touches paths and manifests.

Layout: ``<store>/<kind>/<name>/v<N>/`` holding ``manifest.json`` and data files. A version is
written into ``<store>/.tmp/`` and renamed into place only once every file is fsynced, so a crash
never leaves a half-written version visible. Versions are immutable; a rerun writes ``v<N+1>``.
Runs in progress keep their checkpoints under ``<store>/.runs/<kind>/<name>/``.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import itertools
import json
import os
import re
import shutil
import socket
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from . import __version__
from .envs import EnvInfo
from .errors import LwailError

SCHEMA_VERSION = 2  # 2: the manifest itself is hashed, and children record their parents' manifest hashes
KINDS = ("dataset", "demos", "embedding", "discriminator", "policy", "report")  # a report spans envs: no env
MANIFEST = "manifest.json"
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")  # used with fullmatch: a trailing newline is no name
MAX_NAME = 100
COMMIT_TRIES = 100  # version numbers tried before giving up on a store that other writers keep filling
_REF = re.compile(r"^(?:(?P<kind>[a-z]+)/)?(?P<name>[A-Za-z0-9][A-Za-z0-9._-]*?)(?:@v(?P<version>\d+))?$")


def default_store() -> Path:
    return Path(os.environ.get("LWAIL_STORE", "artifacts"))


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _manifest_hash(manifest: dict) -> str:
    """The whole record (name, version, metrics, parents, ...), so any edit of a manifest is detected on read."""
    body = {key: value for key, value in manifest.items() if key != "manifest_hash"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def _content_hash(file_hashes: dict[str, str], env: dict, config: dict) -> str:
    """What the artifact is: its data files, and the env and config that give them meaning."""
    lines = "".join(f"{name}:{digest}\n" for name, digest in sorted(file_hashes.items()))
    lines += json.dumps({"env": env, "config": config}, sort_keys=True)
    return hashlib.sha256(lines.encode()).hexdigest()


_MANIFEST_TYPES = {"name": str, "version": int, "config": dict, "files": dict, "parents": list, "metrics": dict, "created": str,
                   "hash": str, "manifest_hash": str}  # the entries readers rely on (kind and schema are checked first)


def _malformed(manifest: dict) -> str | None:
    """What is wrong with the shape of a manifest (None if nothing), so a damaged one is refused or listed as
    DAMAGED rather than failing in whichever reader touches the missing entry first."""
    for key, kind in _MANIFEST_TYPES.items():
        if not isinstance(manifest.get(key), kind) or isinstance(manifest.get(key), bool):
            return f"its {key!r} entry is missing or not a {kind.__name__}"
    env = manifest.get("env", False)  # None is legitimate: a report spans environments
    if env is not None and not (isinstance(env, dict) and isinstance(env.get("id"), str)):
        return "its 'env' entry is missing or names no environment id"
    if not all(isinstance(name, str) and isinstance(digest, str) for name, digest in manifest["files"].items()):
        return "its 'files' entry must map file names to hashes"
    if not all(isinstance(entry, dict) and isinstance(entry.get("ref"), str) for entry in manifest["parents"]):
        return "each of its 'parents' must name a ref"
    return None


@dataclass(frozen=True)
class Artifact:
    """A committed, validated artifact version."""

    path: Path
    manifest: dict

    @property
    def kind(self) -> str:
        return self.manifest["kind"]

    @property
    def name(self) -> str:
        return self.manifest["name"]

    @property
    def version(self) -> int:
        return self.manifest["version"]

    @property
    def ref(self) -> str:
        return f"{self.kind}/{self.name}@v{self.version}"

    @property
    def hash(self) -> str:
        return self.manifest["hash"]

    @property
    def env(self) -> EnvInfo:
        if self.manifest["env"] is None:
            raise LwailError(f"{self.ref} belongs to no single environment")
        return EnvInfo.from_dict(self.manifest["env"])

    @property
    def config(self) -> dict:
        return self.manifest["config"]

    @property
    def metrics(self) -> dict:
        return self.manifest.get("metrics", {})

    def file(self, name: str) -> Path:
        return self.path / name

    def append_log(self, filename: str, row: dict) -> Path:
        """Append a row to a CSV that sits beside the artifact's data (not part of its hash)."""
        if filename in self.manifest["files"] or filename == MANIFEST:
            raise LwailError(f"{filename} is a data file of {self.ref} and cannot be appended to")
        target = self.path / filename
        new = not target.exists()
        with open(target, "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(row))
            if new:
                writer.writeheader()
            writer.writerow(row)
        return target


class ArtifactWriter:
    """A version being written: files go into ``directory``; metrics may be added until commit."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.metrics: dict = {}
        self.artifact: Artifact | None = None  # the version this writer committed (not the latest: writers race)

    def path(self, filename: str) -> Path:
        return self.directory / filename


class Store:
    def __init__(self, root: Path | str | None = None):
        # absolute, because libraries we hand paths to (Minari) mis-join relative ones
        self.root = (Path(root) if root is not None else default_store()).absolute()

    # ---------------------------------------------------------------- reading
    def resolve(self, ref: str, kind: str) -> Artifact:
        """Find ``name``, ``name@vN``, ``kind/name@vN`` or a path, and validate it as ``kind``."""
        path = Path(ref)
        if (path / MANIFEST).is_file():
            artifact = self._load(path)
        else:
            match = _REF.fullmatch(ref)  # fullmatch: '$' alone lets "name\n" through as "name"
            if not match:
                raise LwailError(f"{ref!r} is neither an artifact path nor a name like 'hopper' or 'hopper@v2'")
            ref_kind = match["kind"] or kind
            name = match["name"]
            if not (self.root / ref_kind / name).is_dir():
                elsewhere = [k for k in KINDS if k != ref_kind and (self.root / k / name).is_dir()]
                if elsewhere:
                    raise LwailError(f"{ref!r} is a {elsewhere[0]} artifact, but a {kind} is needed here")
                raise LwailError(f"no {ref_kind} artifact named {name!r} in store {self.root}")
            versions = self._versions(ref_kind, name)
            if not versions:
                raise LwailError(f"no committed version of {ref_kind}/{name} in store {self.root}")
            version = int(match["version"]) if match["version"] else versions[-1]
            if version not in versions:
                raise LwailError(f"{ref_kind}/{name} has no version v{version} (has v{', v'.join(map(str, versions))})")
            artifact = self._load(self.root / ref_kind / name / f"v{version}")
        if artifact.kind != kind:
            raise LwailError(f"{ref!r} is a {artifact.kind} artifact, but a {kind} is needed here")
        return artifact

    def resolve_any(self, ref: str) -> Artifact:
        """``kind/name[@vN]`` or an artifact path, whatever its kind."""
        path = Path(ref)
        if (path / MANIFEST).is_file():
            return self._load(path)
        kind = ref.split("/")[0] if "/" in ref else None
        if kind not in KINDS:
            raise LwailError(f"give kind/name (e.g. policy/hopper-v5-expert) or an artifact path, not {ref!r}")
        return self.resolve(ref, kind)

    def resolve_parent(self, child: Artifact, kind: str) -> Artifact | None:
        """The direct parent of ``kind`` a child was made from, refused if it changed since (None if it has none)."""
        for entry in child.manifest.get("parents", []):
            if entry["ref"].split("/")[0] == kind:
                found = self.resolve(entry["ref"], kind)
                if found.manifest["manifest_hash"] != entry.get("manifest_hash"):
                    raise LwailError(f"{found.ref} was changed after {child.ref} was made from it")
                return found
        return None

    def verify(self, ref: str | None = None) -> list[tuple[str, str | None]]:
        """Every file of one artifact (every version of every artifact without ``ref``): (path, problem or None)."""
        if ref is not None:
            paths = [self.resolve_any(ref).path]
        else:
            paths = [folder / f"v{version}" for kind in KINDS if (self.root / kind).is_dir()
                     for folder in sorted((self.root / kind).iterdir()) for version in self._versions(kind, folder.name)]
        results = []
        for path in paths:
            try:
                artifact = self._load(path)
                for kind in {entry["ref"].split("/")[0] for entry in artifact.manifest.get("parents", [])}:
                    self.resolve_parent(artifact, kind)
                results.append((str(path), None))
            except LwailError as exc:  # a malformed manifest included (_malformed)
                results.append((str(path), str(exc)))
        return results

    def _load(self, path: Path) -> Artifact:
        try:
            manifest = json.loads((path / MANIFEST).read_text())
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise LwailError(f"cannot read the manifest of {path}: {exc}") from None
        if not isinstance(manifest, dict):
            raise LwailError(f"{path / MANIFEST} is not a manifest")
        if manifest.get("schema_version") != SCHEMA_VERSION:
            raise LwailError(
                f"{path} has schema version {manifest.get('schema_version')}; this lwail reads {SCHEMA_VERSION}"
            )
        if manifest.get("kind") not in KINDS:
            raise LwailError(f"{path} has unknown kind {manifest.get('kind')!r}")
        problem = _malformed(manifest)
        if problem is not None:
            raise LwailError(f"{path / MANIFEST} is damaged: {problem}")
        file_hashes = manifest["files"]
        for filename, expected in file_hashes.items():
            if Path(filename).is_absolute() or ".." in Path(filename).parts:
                raise LwailError(f"{path / MANIFEST} names a file outside its artifact: {filename!r}")
            target = path / filename
            if not target.is_file():
                raise LwailError(f"{path} is missing its data file {filename}")
            if _sha256(target) != expected:
                raise LwailError(f"{path}/{filename} does not match its recorded hash: the artifact was modified")
        if _content_hash(file_hashes, manifest.get("env"), manifest.get("config")) != manifest.get("hash"):
            raise LwailError(f"{path} has an inconsistent content hash in its manifest")
        if _manifest_hash(manifest) != manifest.get("manifest_hash"):
            raise LwailError(f"{path / MANIFEST} was edited after it was written (its manifest hash does not match)")
        return Artifact(path=path, manifest=manifest)

    def _versions(self, kind: str, name: str) -> list[int]:
        folder = self.root / kind / name
        if not folder.is_dir():
            return []
        found = (re.fullmatch(r"v(\d+)", p.name) for p in folder.iterdir())
        return sorted(int(m[1]) for m in found if m and (folder / m[0] / MANIFEST).is_file())

    def list(self) -> list[tuple[str, str, list[int], dict | None]]:
        """Every (kind, name, versions, latest manifest) in the store, without re-hashing data; the manifest is
        None where it cannot be read (``lwail verify`` says why)."""
        rows = []
        for kind in KINDS:
            folder = self.root / kind
            if not folder.is_dir():
                continue
            for name_dir in sorted(folder.iterdir()):
                versions = self._versions(kind, name_dir.name)
                if versions:
                    try:
                        manifest = json.loads((name_dir / f"v{versions[-1]}" / MANIFEST).read_text())
                    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
                        manifest = None
                    listable = isinstance(manifest, dict) and _malformed(manifest) is None
                    rows.append((kind, name_dir.name, versions, manifest if listable else None))
        return rows

    # ---------------------------------------------------------------- writing
    @contextlib.contextmanager
    def create(
        self,
        kind: str,
        name: str,
        *,
        env: EnvInfo | None,
        config: dict,
        seed: int | None,
        parents: list[Artifact] = (),
        extra: dict | None = None,
    ) -> Iterator[ArtifactWriter]:
        """Write a new version atomically; nothing becomes visible unless the block completes."""
        if kind not in KINDS:
            raise ValueError(f"unknown artifact kind {kind}")
        check_name(name)
        tmp_root = self.root / ".tmp"
        tmp_root.mkdir(parents=True, exist_ok=True)
        _remove_abandoned(tmp_root)
        # the writer's host and pid in the name, so a later writer can tell an abandoned folder from a live one
        directory = Path(tempfile.mkdtemp(prefix=f"{socket.gethostname()}+{os.getpid()}+{kind}-{name}-", dir=tmp_root))
        writer = ArtifactWriter(directory)
        try:
            yield writer
            writer.artifact = self._load(self._commit(writer, kind, name, env, config, seed, parents, extra or {}))
        finally:
            shutil.rmtree(directory, ignore_errors=True)

    def _commit(self, writer, kind, name, env, config, seed, parents, extra) -> Path:
        file_hashes = {}
        for target in sorted(writer.directory.rglob("*")):
            if target.is_file():
                with open(target, "rb+") as handle:
                    os.fsync(handle.fileno())
                file_hashes[str(target.relative_to(writer.directory))] = _sha256(target)
        manifest = {
            "kind": kind,
            "schema_version": SCHEMA_VERSION,
            "name": name,
            "version": None,
            "env": None if env is None else env.to_dict(),
            "config": config,
            "seed": seed,
            "parents": [{"ref": p.ref, "hash": p.hash, "manifest_hash": p.manifest["manifest_hash"]} for p in parents],
            "package_version": __version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "metrics": writer.metrics,
            "files": file_hashes,
            "hash": _content_hash(file_hashes, None if env is None else env.to_dict(), config),
            **extra,
        }
        parent_dir = self.root / kind / name
        parent_dir.mkdir(parents=True, exist_ok=True)
        version = (self._versions(kind, name) or [0])[-1] + 1
        for _ in range(COMMIT_TRIES):
            manifest["version"] = version
            manifest["manifest_hash"] = _manifest_hash(manifest)
            manifest_path = writer.directory / MANIFEST
            manifest_path.write_text(json.dumps(manifest, indent=2))
            with open(manifest_path, "rb+") as handle:
                os.fsync(handle.fileno())
            try:
                os.rename(writer.directory, parent_dir / f"v{version}")
                break
            except OSError as exc:
                if not (parent_dir / f"v{version}").exists():  # not a concurrent writer: a store we cannot write
                    raise LwailError(f"cannot write {parent_dir / f'v{version}'}: {exc.strerror or exc}") from None
                version += 1  # a concurrent writer took this version number
        else:
            raise LwailError(f"gave up writing {kind}/{name}: {COMMIT_TRIES} version numbers were taken by other writers")
        _fsync_dir(parent_dir)
        return parent_dir / f"v{version}"

    # ---------------------------------------------------------------- checkpoints of runs in progress
    def _checkpoint_path(self, kind: str, name: str) -> Path:
        check_name(name)
        return self.root / ".runs" / kind / name / "checkpoint.pt"

    @contextlib.contextmanager
    def claim_run(self, kind: str, name: str, *, resume: bool) -> Iterator[None]:
        """One run per name at a time, and a fresh run never overwrites the checkpoint a killed run left.

        A refused command leaves the store as it was: the claim's own checks come before its lock is written, and a
        run refused inside the claim (its caller checks the checkpoint there) before it wrote anything gets its
        folder back as it was found, a killed process's lock included."""
        folder = self._checkpoint_path(kind, name).parent
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
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(".partial")
        with open(partial, "wb") as handle:
            torch.save(state, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(partial, path)
        return path

    def load_checkpoint(self, kind: str, name: str) -> dict:
        import torch

        path = self._checkpoint_path(kind, name)
        if not path.is_file():
            raise LwailError(f"--resume: no checkpoint for {kind}/{name} in store {self.root}")
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

    def run_log(self, kind: str, name: str, filename: str) -> Path:
        """A CSV a run in progress (or a killed one) keeps beside its checkpoint."""
        check_name(name)
        return self.root / ".runs" / kind / name / filename

    def write_run_log(self, kind: str, name: str, filename: str, rows: list[dict]) -> None:
        """Rewrite a run's CSV atomically, so a reader never sees half a row (columns: every key, first seen first)."""
        path = self.run_log(kind, name, filename)
        path.parent.mkdir(parents=True, exist_ok=True)
        columns = list(dict.fromkeys(key for row in rows for key in row))
        partial = path.with_suffix(".partial")
        with open(partial, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=columns)
            writer.writeheader()
            writer.writerows(rows)
        os.replace(partial, path)

    def has_checkpoint(self, kind: str, name: str) -> bool:
        return self._checkpoint_path(kind, name).is_file()

    # ---------------------------------------------------------------- a sweep's ledger of finished stages
    def _ledger_entry(self, sweep: str, key: str) -> Path:
        check_name(sweep)
        if not re.fullmatch(r"[a-z0-9-]{1,100}", key):
            raise ValueError(f"bad ledger key {key!r}")
        return self.root / ".runs" / "sweep" / sweep / f"{key}.ref"

    def finished_stage(self, sweep: str, key: str, kind: str, name: str) -> Artifact | None:
        """The artifact ``kind/name`` a sweep recorded for a stage fingerprint, if it is still there and intact; None
        otherwise (removed, damaged, or an entry naming anything else), so the stage runs again."""
        recorded = (_read_small(self._ledger_entry(sweep, key)) or b"").decode(errors="replace").strip()
        match = _REF.fullmatch(recorded)
        if match is None or (match["kind"], match["name"]) != (kind, name) or match["version"] is None:
            return None
        try:
            return self.resolve(recorded, kind)
        except LwailError:
            return None

    def record_finished_stage(self, sweep: str, key: str, artifact: Artifact) -> None:
        _write_atomically(self._ledger_entry(sweep, key), artifact.ref)

    def _status_path(self, sweep: str, run: str) -> Path:
        check_name(sweep)
        check_name(run)
        return self.root / ".runs" / "sweep" / sweep / f"{run}.status"

    def set_sweep_status(self, sweep: str, run: str, line: str) -> None:
        """What a sweep's run (named by its policy) is doing now, for the sweep's driver to show."""
        _write_atomically(self._status_path(sweep, run), line)

    def sweep_status(self, sweep: str, run: str) -> str | None:
        line = _read_small(self._status_path(sweep, run))
        return None if line is None else line.decode(errors="replace")

    def clear_sweep_status(self, sweep: str, run: str) -> None:
        self._status_path(sweep, run).unlink(missing_ok=True)

    def clear_checkpoint(self, kind: str, name: str) -> None:
        shutil.rmtree(self._checkpoint_path(kind, name).parent, ignore_errors=True)


def check_name(name: str) -> None:
    if not _NAME.fullmatch(name) or len(name) > MAX_NAME:
        raise LwailError(f"artifact name {name!r} must be 1-{MAX_NAME} letters, digits, '.', '_' or '-', starting with a letter or digit")


def _remove_abandoned(tmp_root: Path) -> None:
    """Delete the temp folders of writers on this host that were killed mid-write (never a live writer's)."""
    for folder in tmp_root.iterdir():
        host, _, rest = folder.name.partition("+")
        pid = rest.partition("+")[0]
        if host == socket.gethostname() and pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def _stale_lock(lock: Path, what: str) -> bytes | None:
    """The bytes of a run's lock that a killed process of this host left (to take over), None without a lock. A lock
    of a live process, or of another host, is refused; so is a damaged one (not 'host pid'): whether a process still
    trains the run is the user's call."""
    if not os.path.lexists(lock):
        return None
    held = _read_small(lock)
    found = re.fullmatch(rb"(\S+) ([1-9][0-9]*)", held or b"")
    if found is None:
        raise LwailError(f"the lock {lock} of {what} is damaged (not 'host pid'); if no process is training {what}, delete it")
    host, pid = found[1].decode(errors="replace"), int(found[2])
    if host == socket.gethostname() and not _alive(pid):
        return held
    raise LwailError(f"{what} is being trained by process {pid} on {host}; wait for it, or choose another --name "
                     f"(if that process is gone, delete {lock})")


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


def _write_atomically(path: Path, text: str) -> None:
    """Replace a small file of the run area whole; a folder found in its place (damage) is replaced too."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    partial = path.with_suffix(".partial")
    partial.write_text(text)
    os.replace(partial, path)


def _folder_state(folder: Path) -> dict[str, tuple[int, int]]:
    """Size and modification time of each entry of a run folder but its lock ({} without the folder)."""
    try:
        entries = list(os.scandir(folder))
    except FileNotFoundError:
        return {}
    return {entry.name: (entry.stat(follow_symlinks=False).st_size, entry.stat(follow_symlinks=False).st_mtime_ns)
            for entry in entries if entry.name != "lock"}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # no such process (a pid past the C range cannot be one)
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
