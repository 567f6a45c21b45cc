"""The manifest a version keeps beside its data: what it is, what made it, and the hashes that show it is intact.

Three hashes: each data file's, the content's (data files, env and config: what the artifact *is*), and the
manifest's own (the whole record, so an edited manifest is refused on read). A child records its parents' refs and
manifest hashes, so a parent changed after the child was made from it is refused too.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

from .version import __version__
from .errors import LwailError

if TYPE_CHECKING:
    from .envs import EnvInfo

SCHEMA_VERSION = 2  # 2: the manifest itself is hashed, and children record their parents' manifest hashes
KINDS = ("dataset", "demos", "embedding", "discriminator", "policy", "report")  # a report spans envs: no env
MANIFEST = "manifest.json"
_MANIFEST_TYPES = {"name": str, "version": int, "config": dict, "files": dict, "parents": list, "metrics": dict, "created": str,
                   "hash": str, "manifest_hash": str}  # the entries readers rely on (kind and schema are checked first)


def file_hash(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def new_manifest(kind: str, name: str, env: EnvInfo | None, config: dict, seed: int | None, parents: list[dict],
                 metrics: dict, file_hashes: dict[str, str], extra: dict) -> dict:
    """The record of a version about to be committed; the store fills in its version number and manifest hash."""
    env_record = None if env is None else env.to_dict()
    return {
        "kind": kind,
        "schema_version": SCHEMA_VERSION,
        "name": name,
        "version": None,
        "env": env_record,
        "config": config,
        "seed": seed,
        "parents": parents,
        "package_version": __version__,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "metrics": metrics,
        "files": file_hashes,
        "hash": content_hash(file_hashes, env_record, config),
        **extra,
    }


def manifest_hash(manifest: dict) -> str:
    """The whole record (name, version, metrics, parents, ...), so any edit of a manifest is detected on read."""
    body = {key: value for key, value in manifest.items() if key != "manifest_hash"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def content_hash(file_hashes: dict[str, str], env: dict, config: dict) -> str:
    """What the artifact is: its data files, and the env and config that give them meaning."""
    lines = "".join(f"{name}:{digest}\n" for name, digest in sorted(file_hashes.items()))
    lines += json.dumps({"env": env, "config": config}, sort_keys=True)
    return hashlib.sha256(lines.encode()).hexdigest()


def malformed(manifest: dict) -> str | None:
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


def read_manifest(path: Path) -> dict:
    """The manifest of the version folder ``path``, refused unless it and every data file it names are intact."""
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
    problem = malformed(manifest)
    if problem is not None:
        raise LwailError(f"{path / MANIFEST} is damaged: {problem}")
    file_hashes = manifest["files"]
    for filename, expected in file_hashes.items():
        if Path(filename).is_absolute() or ".." in Path(filename).parts:
            raise LwailError(f"{path / MANIFEST} names a file outside its artifact: {filename!r}")
        target = path / filename
        if not target.is_file():
            raise LwailError(f"{path} is missing its data file {filename}")
        if file_hash(target) != expected:
            raise LwailError(f"{path}/{filename} does not match its recorded hash: the artifact was modified")
    if content_hash(file_hashes, manifest.get("env"), manifest.get("config")) != manifest.get("hash"):
        raise LwailError(f"{path} has an inconsistent content hash in its manifest")
    if manifest_hash(manifest) != manifest.get("manifest_hash"):
        raise LwailError(f"{path / MANIFEST} was edited after it was written (its manifest hash does not match)")
    return manifest
