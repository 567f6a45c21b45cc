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
            match = _REF.match(ref)
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
            except (LwailError, KeyError, TypeError, AttributeError) as exc:
                results.append((str(path), str(exc) if isinstance(exc, LwailError) else f"malformed manifest ({type(exc).__name__}: {exc})"))
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
        file_hashes = manifest.get("files", {})
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
                    rows.append((kind, name_dir.name, versions, manifest if isinstance(manifest, dict) else None))
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
        """One run per name at a time, and a fresh run never overwrites the checkpoint a killed run left."""
        folder = self._checkpoint_path(kind, name).parent
        folder.mkdir(parents=True, exist_ok=True)
        lock = folder / "lock"
        owner = f"{socket.gethostname()} {os.getpid()}"
        try:
            self._take_lock(lock, owner, f"{kind}/{name}")
            if not resume and (folder / "checkpoint.pt").exists():
                raise LwailError(
                    f"a killed run of {kind}/{name} left a checkpoint: add --resume to continue it, "
                    f"choose another --name, or delete {folder} to start over"
                )
            yield
        finally:
            if lock.is_file() and lock.read_text() == owner:
                lock.unlink()

    @staticmethod
    def _take_lock(lock: Path, owner: str, what: str) -> None:
        for _ in range(2):
            try:
                with open(lock, "x") as handle:
                    handle.write(owner)
                return
            except FileExistsError:
                host, _, pid = lock.read_text().partition(" ")
                if host == socket.gethostname() and pid.isdigit() and not _alive(int(pid)):
                    lock.unlink(missing_ok=True)  # left by a killed process: take it over
                    continue
                raise LwailError(f"{what} is being trained by process {pid or '?'} on {host or '?'}; wait for it, or choose "
                                 f"another --name (if that process is gone, delete {lock})") from None
        raise LwailError(f"{what}: another process took the run's lock {lock} at the same time")

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
        import pickle

        import torch

        path = self._checkpoint_path(kind, name)
        if not path.is_file():
            raise LwailError(f"--resume: no checkpoint for {kind}/{name} in store {self.root}")
        try:
            return torch.load(path, map_location="cpu", weights_only=True)  # tensors and plain data only: no code runs
        except (RuntimeError, EOFError, OSError, pickle.UnpicklingError, ValueError) as exc:
            raise LwailError(f"--resume: the checkpoint {path} is corrupt ({type(exc).__name__}); rerun without --resume") from None

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

    def finished_stage(self, sweep: str, key: str, kind: str) -> Artifact | None:
        """The artifact a sweep recorded for a stage fingerprint, if it is still there and intact."""
        entry = self._ledger_entry(sweep, key)
        if not entry.is_file():
            return None
        try:
            return self.resolve(entry.read_text().strip(), kind)
        except LwailError:  # removed or damaged since: the stage runs again
            return None

    def record_finished_stage(self, sweep: str, key: str, artifact: Artifact) -> None:
        entry = self._ledger_entry(sweep, key)
        entry.parent.mkdir(parents=True, exist_ok=True)
        partial = entry.with_suffix(".partial")
        partial.write_text(artifact.ref)
        os.replace(partial, entry)

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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
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
