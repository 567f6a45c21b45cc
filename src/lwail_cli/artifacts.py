"""The versioned store. With ``manifests.py`` (the record and its hashes), ``names.py`` (names and refs), the run
area (``run_area.py``) and ``formats/`` (one file format each), the only code that touches paths and manifests.

Layout: ``<store>/<kind>/<name>/v<N>/`` holding ``manifest.json`` and data files. A version is
written into ``<store>/.tmp/`` and renamed into place only once every file is fsynced (``version_writer.py``), so a
crash never leaves a half-written version visible. Versions are immutable; a rerun writes ``v<N+1>``.
Runs in progress keep their checkpoints under ``<store>/.runs/`` (``Store.runs``).
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Iterator

from .envs import EnvInfo
from .errors import LwailError
from .manifests import KINDS, MANIFEST, content_hash, malformed, new_manifest, read_manifest
from .names import check_name, closest, parse_ref
from .run_area import RunArea
from .version_writer import ArtifactWriter, commit_version, staged_version


def default_store() -> Path:
    return Path(os.environ.get("LWAIL_STORE", "artifacts"))


@dataclass(frozen=True)
class Artifact:
    """A committed, validated artifact version."""

    path: Path
    manifest: dict
    reused: bool = False  # found in the store holding what was about to be written (Store.create(reuse_same_content=True))

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

    @property
    def parent_kinds(self) -> list[str]:
        """The kinds of the artifacts this one was made from, in the order its manifest lists them, each once."""
        return list(dict.fromkeys(entry["ref"].split("/")[0] for entry in self.manifest.get("parents", [])))

    def file(self, name: str) -> Path:
        return self.path / name

    def beside(self, filename: str) -> Path:
        """A file kept beside the artifact's data and outside its hash (an evaluation log, a figure drawn later);
        never one of its data files or its manifest."""
        if filename in self.manifest["files"] or filename == MANIFEST:
            raise LwailError(f"{filename} is a data file of {self.ref} and cannot be written beside it")
        return self.path / filename

    def append_log(self, filename: str, row: dict) -> Path:
        """Append a row to a CSV that sits beside the artifact's data (not part of its hash). A row with columns the
        file lacks (written by an older lwail) rewrites the file with them added, empty in its earlier rows."""
        target = self.beside(filename)
        rows, columns, rewrite = [], list(row), not target.exists()
        if target.exists():
            with open(target, newline="") as handle:
                reader = csv.DictReader(handle)
                header = list(reader.fieldnames or [])
                rewrite = not set(columns) <= set(header)
                rows = list(reader) if rewrite else []
                columns = header + [column for column in columns if column not in header]
        with open(target, "w" if rewrite else "a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=columns, restval="")
            if rewrite:
                writer.writeheader()
            writer.writerows([*rows, row])
        return target


class Store:
    def __init__(self, root: Path | str | None = None):
        # absolute, because libraries we hand paths to (Minari) mis-join relative ones
        self.root = (Path(root) if root is not None else default_store()).absolute()
        self.runs = RunArea(self.root)

    # ---------------------------------------------------------------- reading
    def resolve(self, ref: str, kind: str) -> Artifact:
        """Find ``name``, ``name@vN``, ``kind/name@vN`` or a path, and validate it as ``kind``."""
        path = Path(ref)
        if (path / MANIFEST).is_file():
            artifact = self._load(path)
        else:
            parsed = parse_ref(ref)
            if parsed is None:
                raise LwailError(f"{ref!r} is neither an artifact path nor a name like 'hopper' or 'hopper@v2'")
            ref_kind, name, version = parsed
            ref_kind = ref_kind or kind
            if not (self.root / ref_kind / name).is_dir():
                elsewhere = [k for k in KINDS if k != ref_kind and (self.root / k / name).is_dir()]
                if elsewhere:
                    raise LwailError(f"{ref!r} is a {elsewhere[0]} artifact, but a {kind} is needed here")
                raise LwailError(f"no {ref_kind} artifact named {name!r} in store {self.root}; "
                                 f"{closest(name, self._names(ref_kind), f'{ref_kind} artifacts')}")
            versions = self._versions(ref_kind, name)
            if not versions:
                raise LwailError(f"no committed version of {ref_kind}/{name} in store {self.root}")
            version = versions[-1] if version is None else version
            if version not in versions:
                raise LwailError(f"{ref_kind}/{name} has no version v{version} (has v{', v'.join(map(str, versions))})")
            artifact = self._load(self.root / ref_kind / name / f"v{version}")
        if artifact.kind != kind:
            raise LwailError(f"{ref!r} is a {artifact.kind} artifact, but a {kind} is needed here")
        return artifact

    def finished_stage(self, sweep: str, key: str, kind: str, name: str) -> Artifact | None:
        """The artifact ``kind/name`` a sweep recorded for a stage fingerprint, if it is still there and intact; None
        otherwise (removed, damaged, or an entry naming anything else), so the stage runs again."""
        recorded = self.runs.finished_stage_ref(sweep, key, kind, name)
        if recorded is None:
            return None
        try:
            return self.resolve(recorded, kind)
        except LwailError:
            return None

    def resolve_any(self, ref: str) -> Artifact:
        """``name[@vN]`` (a name only one kind holds), ``kind/name[@vN]`` or an artifact path, whatever its kind."""
        path = Path(ref)
        if (path / MANIFEST).is_file():
            return self._load(path)
        parsed = parse_ref(ref)
        if parsed is None:
            raise LwailError(f"{ref!r} is neither an artifact path nor a name like 'hopper', 'hopper@v2' or 'policy/hopper@v2'")
        kind, name, _ = parsed
        if kind is not None:
            if kind not in KINDS:
                raise LwailError(f"unknown artifact kind {kind!r} in {ref!r}; {closest(kind, list(KINDS), 'kinds')}")
            return self.resolve(ref, kind)
        holding = [k for k in KINDS if self._versions(k, name)]
        if len(holding) > 1:
            raise LwailError(f"{name!r} names artifacts of {len(holding)} kinds: give one of {', '.join(f'{k}/{ref}' for k in holding)}")
        if not holding:
            names = sorted({n for k in KINDS for n in self._names(k)})
            raise LwailError(f"no artifact named {name!r} in store {self.root}; {closest(name, names, 'artifacts')}")
        return self.resolve(ref, holding[0])

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
                for kind in artifact.parent_kinds:
                    self.resolve_parent(artifact, kind)
                results.append((str(path), None))
            except LwailError as exc:  # a malformed manifest included (manifests.malformed)
                results.append((str(path), str(exc)))
        return results

    def _load(self, path: Path) -> Artifact:
        return Artifact(path=path, manifest=read_manifest(path))

    def _names(self, kind: str) -> list[str]:
        """The names of ``kind`` with at least one committed version."""
        folder = self.root / kind
        return sorted(p.name for p in folder.iterdir() if self._versions(kind, p.name)) if folder.is_dir() else []

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
                    listable = isinstance(manifest, dict) and malformed(manifest) is None
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
        reuse_same_content: bool = False,
    ) -> Iterator[ArtifactWriter]:
        """Write a new version atomically; nothing becomes visible unless the block completes. With
        ``reuse_same_content`` (an import), a latest version with the same content hash is kept instead (``reused``)."""
        if kind not in KINDS:
            raise ValueError(f"unknown artifact kind {kind}")
        check_name(name)
        with staged_version(self.root, kind, name) as writer:
            yield writer
            existing = self._latest_with_same_content(writer, kind, name, env, config) if reuse_same_content else None
            if existing is None:
                lineage = [{"ref": p.ref, "hash": p.hash, "manifest_hash": p.manifest["manifest_hash"]} for p in parents]
                manifest = new_manifest(kind, name, env, config, seed, lineage, writer.metrics, writer.file_hashes(), extra or {})
                next_version = (self._versions(kind, name) or [0])[-1] + 1
                existing = self._load(commit_version(writer, manifest, self.root / kind / name, next_version))
            writer.artifact = existing

    def _latest_with_same_content(self, writer, kind, name, env, config) -> Artifact | None:
        """The latest version of ``kind/name`` if its content hash is the one ``writer``'s files would get (only the
        latest: a name then still refers to what was just written); None if it differs, or is damaged."""
        versions = self._versions(kind, name)
        if not versions:
            return None
        try:
            latest = self._load(self.root / kind / name / f"v{versions[-1]}")
        except LwailError:
            return None
        if latest.hash != content_hash(writer.file_hashes(), None if env is None else env.to_dict(), config):
            return None
        return replace(latest, reused=True)
