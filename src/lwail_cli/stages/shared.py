"""What several stages need: devices, names, weights on disk, loading artifacts into models, lineage,
reference returns, and the one skeleton of an online TD3 run (an expert, or LWAIL)."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import torch
from safetensors.torch import load_file, save_file

from .. import config as cfg
from .. import learning_curve
from ..data import Episode, transition_pairs, validate_episodes
from ..discriminator import Critic, transition_features
from ..envs import EnvInfo, describe_env
from ..errors import LwailError
from ..evaluation import Reference, d4rl_reference, random_policy_return
from ..formats.imitation_trajectories import read_imitation
from ..formats.minari_hdf5 import load_local_minari, read_minari_directory
from ..formats.npz import read_npz
from ..icvf import Encoder
from ..replay import ReplayBuffer
from ..td3 import TD3, Actor
from ..training import RunState, train_td3

if TYPE_CHECKING:
    from ..artifacts import Artifact, ArtifactWriter, Store
    from ..training import RewardModel


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


# ------------------------------------------------------------------------------ weights
def save_weights(path: Path, weights: dict[str, torch.Tensor]) -> None:
    save_file({k: v.detach().cpu().contiguous() for k, v in weights.items()}, str(path))


def load_weights(module: torch.nn.Module, artifact: Artifact, filename: str) -> None:
    try:
        module.load_state_dict(load_file(str(artifact.file(filename))))
    except (RuntimeError, KeyError) as exc:
        raise LwailError(f"{artifact.ref} holds weights in {filename} that do not fit its recorded config: {exc}") from None


# ------------------------------------------------------------------------------ artifacts into models and arrays
def load_dataset(artifact: Artifact) -> list[Episode]:
    return read_minari_directory(artifact.file("minari"), artifact.ref)[0]


def load_demos(artifact: Artifact) -> tuple[list[Episode], np.ndarray]:
    return read_npz(artifact.file("demos.npz"))


def load_policy(artifact: Artifact, device: torch.device | str = "cpu") -> Actor:
    actor = Actor.for_env(artifact.env, tuple(artifact.config["td3"]["hidden"]))
    load_weights(actor, artifact, "actor.safetensors")
    return actor.to(device).eval()


def policy_fn(actor: Actor) -> Callable[[np.ndarray], np.ndarray]:
    """The actor as a numpy policy: a batch of observations (any float dtype) to a batch of actions."""
    device = next(actor.parameters()).device

    @torch.inference_mode()
    def act(obs: np.ndarray) -> np.ndarray:
        return actor(torch.as_tensor(obs, dtype=torch.float32, device=device)).cpu().numpy()

    return act


def load_encoder(artifact: Artifact, device: torch.device | str = "cpu") -> Encoder:
    record = artifact.config
    icvf_config = cfg.from_dict(cfg.ICVFConfig, record["icvf"]) if record["type"] == "icvf" else None
    encoder = Encoder(record["obs_dim"], icvf_config)
    if icvf_config is not None:
        load_weights(encoder, artifact, "phi.safetensors")
    return encoder.to(device).requires_grad_(False).eval()


def critic_config(disc: Artifact) -> cfg.CriticConfig:
    """The settings f was warmed up with: the ones every later update of f must use."""
    return cfg.from_dict(cfg.CriticConfig, disc.config["critic"])


def load_critic(artifact: Artifact, device: torch.device | str = "cpu") -> Critic:
    critic = Critic(artifact.config["input_dim"], critic_config(artifact).hidden)
    load_weights(critic, artifact, "critic.safetensors")
    return critic.to(device)


@torch.no_grad()
def pair_features(encoder: Encoder, states: np.ndarray, next_states: np.ndarray, device) -> torch.Tensor:
    return transition_features(encoder, torch.as_tensor(states, device=device), torch.as_tensor(next_states, device=device))


def expert_pairs(demos: Artifact, episodes_wanted: int) -> tuple[np.ndarray, np.ndarray]:
    episodes, _ = load_demos(demos)
    if episodes_wanted > len(episodes):
        raise LwailError(f"--expert-episodes {episodes_wanted}: {demos.ref} holds only {len(episodes)} episodes")
    return transition_pairs(episodes[:episodes_wanted])


# ------------------------------------------------------------------------------ lineage and references
def parent(store: Store, artifact: Artifact, kind: str) -> Artifact:
    """The direct parent of ``kind`` an artifact was made from (refused if it changed since)."""
    found = store.resolve_parent(artifact, kind)
    if found is None:
        raise LwailError(f"{artifact.ref} records no {kind} parent")
    return found


def lineage_demos(store: Store, artifact: Artifact) -> Artifact | None:
    """The demos an artifact was (transitively) made from, if any."""
    for kind in dict.fromkeys(entry["ref"].split("/")[0] for entry in artifact.manifest.get("parents", [])):
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


# ------------------------------------------------------------------------------ online TD3 runs
@dataclass
class TrainingRun:
    """An online run's checkpoint hook and the state it resumes from (None for a fresh run)."""

    resume: dict | None
    on_checkpoint: Callable[[dict], None]


def prepare_run(store: Store, kind: str, name: str, resume: bool, record: dict) -> TrainingRun:
    """Checkpoints carry what made the run (config, seed, env, parents); a resume under anything else is refused.
    A resume may change an online run's budget (``train.steps``, see ``train_policy``) and its evaluation and
    checkpoint schedule (``cfg.RESUME_MAY_CHANGE``): e.g. evaluate every 1k steps to look closely at part of a run."""
    state = store.runs.load_checkpoint(kind, name) if resume else None
    if state is not None:
        recorded = state.get("record", {})
        changed = [key for key in record if _what_trains(recorded.get(key)) != _what_trains(record[key])]
        if changed:
            raise LwailError(
                f"the checkpoint of {kind}/{name} was made with another {' and '.join(changed)}; "
                f"rerun with the same options (only {', '.join('train.' + key for key in cfg.RESUME_MAY_CHANGE)} may differ), "
                "or without --resume"
            )
    return TrainingRun(resume=state, on_checkpoint=lambda checkpoint: store.runs.save_checkpoint(kind, name, {**checkpoint, "record": record}))


def _what_trains(value):
    """A recorded config without the ``train`` keys a resume may change (anything else unchanged)."""
    if not isinstance(value, dict) or "train" not in value:
        return value
    return {**value, "train": {k: v for k, v in value["train"].items() if k not in cfg.RESUME_MAY_CHANGE}}


@dataclass(frozen=True)
class PolicyRun:
    """What distinguishes one kind of online TD3 run from another."""

    env_id: str
    name: str
    config: cfg.ExpertConfig | cfg.ImitationConfig
    seed: int
    parents: list
    trained_on: str
    reference: Reference | None
    reward_model: Callable[[int], RewardModel] | None  # builds it for a buffer capacity (after seeding torch)
    write: Callable[[ArtifactWriter, RunState, TD3, RewardModel | None], None]  # the stage's own files and metrics
    recorded: dict | None = None  # the manifest's config, when more than ``config`` (default: ``config``)
    feature_width: int = 0  # floats the reward model caches per buffered transition (LWAIL's pair features)


def train_policy(store: Store, run: PolicyRun, *, device: torch.device, resume: bool, on_progress: Progress | None = None) -> Artifact:
    """Seed, build, train (resumably) and write a policy artifact: the skeleton of `expert train` and `imitate`."""
    info = describe_env(run.env_id)
    record = cfg.to_dict(run.config) if run.recorded is None else run.recorded
    with store.runs.claim_run("policy", run.name, resume=resume):
        checkpoints = prepare_run(store, "policy", run.name, resume, {
            "config": record, "seed": run.seed, "env": run.env_id, "parents": [p.hash for p in run.parents]
        })
        if checkpoints.resume is not None and checkpoints.resume["run"]["step"] > run.config.train.steps:
            # a run continues to a longer budget, or stops where it stands with --steps = the checkpoint's step
            reached = checkpoints.resume["run"]["step"]
            raise LwailError(f"the checkpoint of policy/{run.name} is at step {reached}: --steps must be at least {reached}")

        def log_curve(history: list[dict]) -> None:
            store.runs.write_run_log("policy", run.name, learning_curve.FILE, history)  # beside the checkpoint

        if checkpoints.resume is not None:  # drop rows a killed run logged after its last checkpoint
            log_curve(checkpoints.resume["run"]["history"])
        capacity = min(run.config.td3.buffer_size, run.config.train.steps)
        floats = 2 * info.obs_dim + info.act_dim + 2 + run.feature_width  # s, a, s', r, not-done (+ cached features)
        require_memory(4 * capacity * floats, f"a replay buffer of {capacity} transitions")
        torch.manual_seed(run.seed)
        reward_model = run.reward_model(capacity) if run.reward_model is not None else None
        agent = TD3(info, run.config.td3, device, average_tau=run.config.train.average_tau)
        buffer = ReplayBuffer(capacity, info.obs_dim, info.act_dim, device)
        result = train_td3(
            run.env_id, agent, buffer, run.config.td3, run.config.train, run.seed, reward_model=reward_model,
            reference=run.reference, resume=checkpoints.resume, on_checkpoint=checkpoints.on_checkpoint,
            on_progress=None if on_progress is None else lambda step, state: on_progress(step, run_summary(state)),
            on_evaluation=lambda state: log_curve(state.history),
        )
        extra = {"trained_on": run.trained_on}
        with store.create("policy", run.name, env=info, config=record, seed=run.seed, parents=run.parents, extra=extra) as writer:
            write_history(writer.path(learning_curve.FILE), result)
            run.write(writer, result, agent, reward_model)
            writer.metrics.update(final_metrics(result))
            if run.reference is not None:
                writer.metrics["reference"] = run.reference.source
        store.runs.clear_checkpoint("policy", run.name)
    return writer.artifact


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


def run_summary(run: RunState) -> dict:
    """The latest episode return, evaluation and score of a run in progress; at an evaluation's step, also that
    evaluation's whole row as ``curve/<column>`` (what a live logger records beside the CSV)."""
    shown = {}
    if run.episode_returns:
        shown["ep_return"] = run.episode_returns[-1]
    if run.history:
        last = run.history[-1]
        shown["eval"] = last["return_mean"]
        if "normalized_score" in last:
            shown["score"] = last["normalized_score"]
        if last["step"] == run.step:
            shown.update({f"curve/{column}": value for column, value in last.items() if column != "step"})
    return shown


def write_history(path: Path, run: RunState) -> None:
    import pandas as pd

    pd.DataFrame(run.history).to_csv(path, index=False)


def final_metrics(run: RunState) -> dict:
    last = run.history[-1]
    metrics = {"env_steps": run.step, "wall_time_s": round(run.wall_time, 1), "return_mean": last["return_mean"], "return_std": last["return_std"]}
    if "normalized_score" in last:
        metrics["normalized_score"] = last["normalized_score"]
    return metrics


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
