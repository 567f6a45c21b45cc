"""Writing one artifact version atomically (for ``artifacts.Store.create``, its only user).

A version is written into ``<store>/.tmp/`` and renamed into place only once every file and its manifest are
fsynced, so a crash never leaves a half-written version visible; concurrent writers of one name take the next
free version number.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import LwailError
from .manifests import MANIFEST, file_hash, manifest_hash
from .run_area import abandoned_by

COMMIT_TRIES = 100  # version numbers tried before giving up on a store that other writers keep filling


class ArtifactWriter:
    """A version being written: files go into ``directory``; metrics may be added until commit."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.metrics: dict = {}
        self.artifact = None  # the artifacts.Artifact this writer committed (not the latest: writers race)

    def path(self, filename: str) -> Path:
        return self.directory / filename

    def file_hashes(self) -> dict[str, str]:
        """Each file written so far (relative path -> hash), each first waited for until it is on disk."""
        hashes = {}
        for target in sorted(self.directory.rglob("*")):
            if target.is_file():
                _fsync(target)
                hashes[str(target.relative_to(self.directory))] = file_hash(target)
        return hashes


@contextlib.contextmanager
def staged_version(root: Path, kind: str, name: str) -> Iterator[ArtifactWriter]:
    """A writer on a fresh temp folder of the store at ``root``, removed when the block ends (committed or not)."""
    tmp_root = root / ".tmp"
    tmp_root.mkdir(parents=True, exist_ok=True)
    _remove_abandoned(tmp_root)
    # the writer's host and pid in the name, so a later writer can tell an abandoned folder from a live one
    directory = Path(tempfile.mkdtemp(prefix=f"{socket.gethostname()}+{os.getpid()}+{kind}-{name}-", dir=tmp_root))
    try:
        yield ArtifactWriter(directory)
    finally:
        shutil.rmtree(directory, ignore_errors=True)


def commit_version(writer: ArtifactWriter, manifest: dict, name_dir: Path, version: int) -> Path:
    """Rename the writer's folder to ``name_dir/v<N>`` with its manifest, from ``version`` up to the first free N."""
    name_dir.mkdir(parents=True, exist_ok=True)
    for _ in range(COMMIT_TRIES):
        manifest["version"] = version
        manifest["manifest_hash"] = manifest_hash(manifest)
        manifest_path = writer.directory / MANIFEST
        manifest_path.write_text(json.dumps(manifest, indent=2))
        _fsync(manifest_path)
        try:
            os.rename(writer.directory, name_dir / f"v{version}")
            break
        except OSError as exc:
            if not (name_dir / f"v{version}").exists():  # not a concurrent writer: a store we cannot write
                raise LwailError(f"cannot write {name_dir / f'v{version}'}: {exc.strerror or exc}") from None
            version += 1  # a concurrent writer took this version number
    else:
        raise LwailError(f"gave up writing {name_dir.parent.name}/{name_dir.name}: {COMMIT_TRIES} version numbers were taken by other writers")
    _fsync(name_dir)
    return name_dir / f"v{version}"


def _remove_abandoned(tmp_root: Path) -> None:
    """Delete the temp folders of writers on this host that were killed mid-write (never a live writer's)."""
    for folder in tmp_root.iterdir():
        host, _, rest = folder.name.partition("+")
        pid = rest.partition("+")[0]
        if pid.isdigit() and abandoned_by(host, int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def _fsync(path: Path) -> None:
    """Wait until a file, or a folder's list of entries, is on disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
