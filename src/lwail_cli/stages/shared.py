"""What several stages need: names, devices, the critic's input features, lineage, reference returns, a memory
check, and reading external episode files."""

from __future__ import annotations

import json
import time
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import torch

from ..data import Episode, transition_pairs, validate_episodes
from ..discriminator import transition_features
from ..envs import EnvInfo
from ..errors import LwailError
from ..evaluation import Reference, d4rl_reference, random_policy_return
from ..formats.imitation_trajectories import read_imitation
from ..formats.minari_hdf5 import load_local_minari
from ..formats.npz import read_npz
from ..loaders import load_demos

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store
    from ..nets import Encoder


Progress = Callable[[int, dict], None]  # (work done so far, latest figures to show): how every stage reports


def default_name(env_id: str, suffix: str) -> str:
    return f"{env_id.lower()}-{suffix}"


def now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


def resolve_device(device: str) -> torch.device:
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        resolved = torch.device(device)
    except RuntimeError:
        raise LwailError(f"unknown device {device!r} (use cpu, cuda, cuda:N or auto)") from None
    if resolved.type == "cuda" and not torch.cuda.is_available():
        raise LwailError("--device cuda was asked for, but torch sees no CUDA device here")
    return resolved


@torch.no_grad()
def pair_features(encoder: Encoder, states: np.ndarray, next_states: np.ndarray, device) -> torch.Tensor:
    return transition_features(encoder, torch.as_tensor(states, device=device), torch.as_tensor(next_states, device=device))


def expert_pairs(demos: Artifact, episodes_wanted: int) -> tuple[np.ndarray, np.ndarray]:
    episodes, _ = load_demos(demos)
    if episodes_wanted > len(episodes):
        raise LwailError(f"--expert-episodes {episodes_wanted}: {demos.ref} holds only {len(episodes)} episodes")
    return transition_pairs(episodes[:episodes_wanted])


# ------------------------------------------------------------------------------ lineage and references
def lineage_demos(store: Store, artifact: Artifact) -> Artifact | None:
    """The demos an artifact was (transitively) made from, if any."""
    for kind in artifact.parent_kinds:
        found = store.resolve_parent(artifact, kind)
        if kind == "demos":
            return found
        deeper = lineage_demos(store, found)
        if deeper is not None:
            return deeper
    return None


def bundled_experts() -> dict:
    return json.loads((resources.files("lwail_cli") / "demos" / "experts.json").read_text())


def reference_for_env(env_id: str, demos: Artifact | None = None) -> Reference | None:
    """D4RL's values, else a Minari dataset's refs, else the demos' (or bundled) expert return
    against a measured random-policy return; None when there is nothing to compare with."""
    reference = d4rl_reference(env_id)
    if reference is not None:
        return reference
    metrics = demos.metrics if demos is not None else {}
    if "ref_min_score" in metrics and "ref_max_score" in metrics:
        return Reference(metrics["ref_min_score"], metrics["ref_max_score"], f"Minari refs of {demos.ref}")
    if "mean_return" in metrics:
        expert, source = metrics["mean_return"], f"mean return of {demos.ref}"
    elif env_id in bundled_experts():
        expert, source = bundled_experts()[env_id]["mean_return"], f"bundled {env_id} expert return"
    else:
        return None
    random = random_policy_return(env_id)
    return Reference(random, expert, f"{source} ({expert:.1f}) vs measured random-policy return ({random:.1f})")


def expert_return(env_id: str, demos: Artifact | None) -> float | None:
    """Our expert's mean return on the task: the demos' (the policy's own, or those given), else the bundled expert's."""
    if demos is not None and "mean_return" in demos.metrics:
        return float(demos.metrics["mean_return"])
    return bundled_experts().get(env_id, {}).get("mean_return")


def require_memory(needed: int, what: str) -> None:
    """Refuse up front what would not fit: the OS grants huge zeroed tensors lazily and kills the run hours later."""
    available = available_memory()
    if available is not None and needed > available:
        raise LwailError(f"{what} needs {needed / 2**30:.1f} GiB of memory, {available / 2**30:.1f} GiB is available: "
                         "lower td3.buffer_size (--set td3.buffer_size=N) or --steps")


def available_memory() -> int | None:
    """Bytes the kernel says can be allocated without swapping (Linux); None where unknown."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


# ------------------------------------------------------------------------------ external data
def read_external(info: EnvInfo, *, minari_id: str | None = None, npz: Path | None = None,
                  imitation: Path | None = None) -> tuple[list[Episode], str, dict]:
    """Episodes from a local Minari dataset, a .npz or imitation's trajectories, checked against the env; plus
    Minari's refs and the file's returns."""
    if sum(source is not None for source in (minari_id, npz, imitation)) != 1:
        raise LwailError("give exactly one of --from-minari DATASET_ID, --from-file FILE.npz or --from-imitation PATH")
    extra: dict = {}
    if minari_id is not None:
        episodes, metadata = load_local_minari(minari_id)
        source = f"minari:{minari_id}"
        for key in ("ref_min_score", "ref_max_score"):
            value = metadata.get(key)
            if value is not None:
                if not isinstance(value, (int, float)) or not np.isfinite(value):
                    raise LwailError(f"{source} has {key}={value!r}; expected a finite number")
                extra[key] = float(value)
    else:
        path = npz if npz is not None else imitation
        if not path.exists():
            raise LwailError(f"no such file or folder: {path}")
        if npz is not None:
            episodes, returns = read_npz(npz)
            if returns is not None:
                extra["returns"] = [float(value) for value in returns]
            source = f"file:{npz.name}"
        else:
            episodes, source = read_imitation(imitation), f"imitation:{imitation.name}"
    validate_episodes(episodes, info, source)
    return episodes, source, extra
