"""Stages: each reads artifacts, runs an algorithm module and writes a new artifact version.

This is where algorithms meet the artifact store. The CLI calls these functions and renders the
progress they report; nothing here prints.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from safetensors.torch import load_file, save_file

from . import config as cfg
from .artifacts import Artifact, Store
from .data import (
    Episode,
    collect_random,
    load_local_minari,
    load_minari_directory,
    read_minari,
    read_npz,
    validate_episodes,
    write_minari,
    write_npz,
)
from .envs import EnvInfo, describe_env, env_info, make_env, require_same_env
from .errors import LwailError
from .evaluation import Reference, d4rl_reference, random_policy_return, rollout_returns
from .replay import ReplayBuffer
from .td3 import TD3, Actor
from .training import RunState, train_td3



def require_positive(value: int, what: str) -> None:
    if value <= 0:
        raise LwailError(f"{what} must be positive, got {value}")


def default_name(env_id: str, suffix: str) -> str:
    return f"{env_id.lower()}-{suffix}"


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


# ------------------------------------------------------------------------------ datasets
def collect(store: Store, env_id: str, transitions: int, seed: int, name: str | None, on_step=None) -> Artifact:
    require_positive(transitions, "--transitions")
    env = make_env(env_id, seed=seed)
    try:
        episodes = collect_random(env, transitions, seed, on_step)
        info = env_info(env)
        name = name or default_name(env_id, "random")
        with store.create("dataset", name, env=info, config={"source": "uniform-random", "transitions": transitions}, seed=seed) as writer:
            write_minari(episodes, writer.path("minari"), f"lwail/{name}-v0", env, "uniform-random", "uniform-random policy, state-only use")
            writer.metrics.update(_episode_metrics(episodes))
    finally:
        env.close()
    return store.resolve(f"dataset/{name}", "dataset")


def import_dataset(store: Store, env_id: str, name: str | None, minari_id: str | None, npz: Path | None) -> Artifact:
    info = describe_env(env_id)
    env = make_env(env_id)
    try:
        episodes, source, extra = _read_external(info, minari_id, npz)
        name = name or default_name(env_id, "imported")
        with store.create("dataset", name, env=info, config={"source": source}, seed=None) as writer:
            for episode in episodes:  # a state-only file has neither; Minari's format needs both
                n = episode.length
                episode.actions = episode.actions if episode.actions is not None else np.full((n, info.act_dim), np.nan, np.float32)
                episode.rewards = episode.rewards if episode.rewards is not None else np.full(n, np.nan, np.float32)
            write_minari(episodes, writer.path("minari"), f"lwail/{name}-v0", env, source, f"imported from {source}")
            writer.metrics.update(_episode_metrics(episodes) | extra)
    finally:
        env.close()
    return store.resolve(f"dataset/{name}", "dataset")


def _read_external(info: EnvInfo, minari_id: str | None, npz: Path | None) -> tuple[list[Episode], str, dict]:
    """Episodes from a local Minari dataset or a .npz, checked against the env; plus Minari's refs."""
    if (minari_id is None) == (npz is None):
        raise LwailError("give exactly one of --from-minari DATASET_ID or --from-file FILE.npz")
    extra: dict = {}
    if minari_id is not None:
        dataset = load_local_minari(minari_id)
        episodes, source = read_minari(dataset), f"minari:{minari_id}"
        for key in ("ref_min_score", "ref_max_score"):
            value = dataset.storage.metadata.get(key)
            if value is not None:
                extra[key] = float(value)
    else:
        if not npz.is_file():
            raise LwailError(f"no such file: {npz}")
        episodes, returns = read_npz(npz)
        source = f"file:{npz.name}"
        if returns is not None:
            extra["returns"] = [float(value) for value in returns]
    validate_episodes(episodes, info, source)
    return episodes, source, extra


def load_dataset(artifact: Artifact) -> list[Episode]:
    return load_minari_directory(artifact.file("minari"))


def _episode_metrics(episodes: list[Episode]) -> dict:
    returns = [e.episode_return for e in episodes if e.rewards is not None and np.all(np.isfinite(e.rewards))]
    metrics = {
        "episodes": len(episodes),
        "transitions": int(sum(e.length for e in episodes)),
        "terminations": int(sum(e.terminated for e in episodes)),
    }
    if returns:
        metrics["mean_return"] = float(np.mean(returns))
    return metrics


# ------------------------------------------------------------------------------ policies
def save_actor(path: Path, weights: dict[str, torch.Tensor]) -> None:
    save_file({k: v.detach().cpu().contiguous() for k, v in weights.items()}, str(path))


def load_policy(artifact: Artifact, device: torch.device | str = "cpu") -> Actor:
    actor = Actor.for_env(artifact.env, tuple(artifact.config["td3"]["hidden"]))
    try:
        actor.load_state_dict(load_file(str(artifact.file("actor.safetensors"))))
    except (RuntimeError, KeyError) as exc:
        raise LwailError(f"{artifact.ref} holds actor weights that do not fit its recorded config: {exc}") from None
    return actor.to(device).eval()


def policy_fn(actor: Actor) -> Callable[[np.ndarray], np.ndarray]:
    device = next(actor.parameters()).device

    @torch.inference_mode()
    def act(obs: np.ndarray) -> np.ndarray:
        return actor(torch.as_tensor(obs, device=device)).cpu().numpy()

    return act


@dataclass
class TrainingRun:
    """An online run's checkpoint hook and the state it resumes from (None for a fresh run)."""

    resume: dict | None
    on_checkpoint: Callable[[dict], None]


def prepare_run(store: Store, kind: str, name: str, resume: bool, config) -> TrainingRun:
    """Checkpoints carry the run's config; a resume under another config is refused."""
    recorded = cfg.to_dict(config)
    state = store.load_checkpoint(kind, name) if resume else None
    if state is not None and state.get("config") != recorded:
        raise LwailError(f"the checkpoint of {kind}/{name} was made with another config; rerun with the same options or without --resume")
    return TrainingRun(resume=state, on_checkpoint=lambda checkpoint: store.save_checkpoint(kind, name, {**checkpoint, "config": recorded}))


def train_expert(
    store: Store,
    env_id: str,
    config: cfg.ExpertConfig,
    seed: int,
    name: str | None,
    device: torch.device,
    resume: bool,
    on_progress: Callable[[int, RunState], None] | None = None,
) -> Artifact:
    require_positive(config.train.steps, "--steps")
    info = describe_env(env_id)
    name = name or default_name(env_id, "expert")
    run = prepare_run(store, "policy", name, resume, config)
    torch.manual_seed(seed)
    agent = TD3(info, config.td3, device)
    buffer = ReplayBuffer(min(config.td3.buffer_size, config.train.steps), info.obs_dim, info.act_dim, device)

    result = train_td3(
        env_id, agent, buffer, config.td3, config.train, seed,
        reference=reference_for_env(env_id), resume=run.resume, on_progress=on_progress, on_checkpoint=run.on_checkpoint,
    )
    # an expert may pick its best evaluation: it trains on the true reward anyway
    with store.create("policy", name, env=info, config=cfg.to_dict(config), seed=seed, extra={"trained_on": "true reward"}) as writer:
        save_actor(writer.path("actor.safetensors"), result.best_actor)
        save_actor(writer.path("final_actor.safetensors"), agent.actor.state_dict())
        _write_history(writer.path("training.csv"), result)
        writer.metrics.update(_final_metrics(result))
        writer.metrics.update({"actor": f"best evaluation, at step {result.best_step}", "best_return_mean": result.best_return})
    store.clear_checkpoint("policy", name)
    return store.resolve(f"policy/{name}", "policy")


def _write_history(path: Path, run: RunState) -> None:
    import pandas as pd

    pd.DataFrame(run.history).to_csv(path, index=False)


def _final_metrics(run: RunState) -> dict:
    last = run.history[-1]
    metrics = {"env_steps": run.step, "wall_time_s": round(run.wall_time, 1), "return_mean": last["return_mean"], "return_std": last["return_std"]}
    if "normalized_score" in last:
        metrics["normalized_score"] = last["normalized_score"]
    return metrics


# ------------------------------------------------------------------------------ demos
def record_demos(store: Store, policy_ref: str, episodes: int, seed: int, name: str | None) -> Artifact:
    require_positive(episodes, "--episodes")
    policy = store.resolve(policy_ref, "policy")
    info = policy.env
    require_same_env(info, describe_env(info.id), f"policy {policy.ref}")
    act = policy_fn(load_policy(policy))
    env = make_env(info.id)
    recorded, returns = [], []
    try:
        for index in range(episodes):
            obs, _ = env.reset(seed=seed + index)
            observations, total, done = [obs], 0.0, False
            while not done:
                obs, reward, terminated, truncated, _ = env.step(act(obs.astype(np.float32)))
                observations.append(obs)
                total += float(reward)
                done = terminated or truncated
            recorded.append(Episode(observations=np.asarray(observations, np.float32), terminated=bool(terminated)))
            returns.append(total)
    finally:
        env.close()
    name = name or default_name(info.id, "demos")
    return _write_demos(store, name, info, recorded, np.asarray(returns), {"source": f"policy:{policy.ref}"}, seed, [policy])


def import_demos(store: Store, env_id: str, name: str | None, minari_id: str | None, npz: Path | None) -> Artifact:
    info = describe_env(env_id)
    episodes, source, extra = _read_external(info, minari_id, npz)
    returns = extra.pop("returns", None)
    if returns is None and all(e.rewards is not None for e in episodes):
        returns = [e.episode_return for e in episodes]
    name = name or default_name(env_id, "demos")
    returns = np.asarray(returns if returns is not None else [np.nan] * len(episodes), dtype=np.float64)
    return _write_demos(store, name, info, episodes, returns, {"source": source, **extra}, None, [])


def bundled_demos_path(env_id: str) -> Path:
    path = resources.files("lwail_cli") / "demos" / f"{env_id}.npz"
    if not path.is_file():
        available = sorted(p.name[:-4] for p in (resources.files("lwail_cli") / "demos").iterdir() if p.name.endswith(".npz"))
        raise LwailError(f"no bundled demos for {env_id}; bundled: {', '.join(available) or 'none'}")
    return Path(str(path))


def bundled_experts() -> dict:
    return json.loads((resources.files("lwail_cli") / "demos" / "experts.json").read_text())


def import_bundled_demos(store: Store, env_id: str, name: str | None) -> Artifact:
    return import_demos(store, env_id, name or default_name(env_id, "bundled-demos"), None, bundled_demos_path(env_id))


def _write_demos(store, name, info, episodes, returns, config, seed, parents) -> Artifact:
    validate_episodes(episodes, info, f"demos {name}")
    with store.create("demos", name, env=info, config=config, seed=seed, parents=parents) as writer:
        write_npz(writer.path("demos.npz"), episodes, returns)
        writer.metrics.update({"episodes": len(episodes), "transitions": int(sum(e.length for e in episodes))})
        if np.all(np.isfinite(returns)):
            writer.metrics.update({"mean_return": float(returns.mean()), "return_std": float(returns.std())})
        for key in ("ref_min_score", "ref_max_score"):
            if key in config:
                writer.metrics[key] = config[key]
    return store.resolve(f"demos/{name}", "demos")


def load_demos(artifact: Artifact) -> tuple[list[Episode], np.ndarray]:
    return read_npz(artifact.file("demos.npz"))


# ------------------------------------------------------------------------------ evaluation
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


def lineage_demos(store: Store, artifact: Artifact) -> Artifact | None:
    """The demos an artifact was (transitively) made from, if any."""
    for parent in artifact.manifest.get("parents", []):
        kind = parent["ref"].split("/")[0]
        found = store.resolve(parent["ref"], kind)
        if kind == "demos":
            return found
        deeper = lineage_demos(store, found)
        if deeper is not None:
            return deeper
    return None


def evaluate(store: Store, policy_ref: str, episodes: int, seed: int, normalized: bool, demos_ref: str | None) -> dict:
    require_positive(episodes, "--episodes")
    policy = store.resolve(policy_ref, "policy")
    require_same_env(policy.env, describe_env(policy.env.id), f"policy {policy.ref}")
    returns = rollout_returns(policy.env.id, policy_fn(load_policy(policy)), episodes, seed)
    result = {"policy": policy.ref, "episodes": episodes, "seed": seed, "return_mean": float(returns.mean()), "return_std": float(returns.std())}
    if normalized:
        demos = store.resolve(demos_ref, "demos") if demos_ref else lineage_demos(store, policy)
        if demos is not None:
            require_same_env(policy.env, demos.env, f"demos {demos.ref}")
        reference = reference_for_env(policy.env.id, demos)
        if reference is None:
            raise LwailError(f"no reference returns for {policy.env.id}: pass --demos with demos that carry returns")
        result.update(normalized_score=reference.normalize(result["return_mean"]), reference=reference.source)
    policy.append_log("evals.csv", {"created": _now(), **result})
    return result


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


# ------------------------------------------------------------------------------ embedding
def pretrain_icvf(
    store: Store,
    data_ref: str,
    config: cfg.ICVFConfig,
    seed: int,
    name: str | None,
    device: torch.device,
    identity: bool,
    on_progress: Callable[[int, float], None] | None = None,
) -> Artifact:
    from .icvf import pretrain_icvf as train, probe_spearman, split_episodes

    dataset = store.resolve(data_ref, "dataset")
    info = dataset.env
    episodes = load_dataset(dataset)
    validate_episodes(episodes, info, f"dataset {dataset.ref}")
    name = name or default_name(info.id, "identity" if identity else "icvf")
    if identity:
        held_out = split_episodes(episodes, config.holdout_fraction, seed)[1]
        probe = probe_spearman(lambda x: x, held_out)
        record = {"type": "identity", "obs_dim": info.obs_dim, "embedding_dim": info.obs_dim}
        with store.create("embedding", name, env=info, config=record, seed=seed, parents=[dataset]) as writer:
            writer.metrics.update({"probe_spearman": probe, "probe_spearman_raw": probe})
        return store.resolve(f"embedding/{name}", "embedding")
    require_positive(config.steps, "--steps")
    result = train(episodes, info.obs_dim, config, seed, device, on_progress)
    record = {"type": "icvf", "obs_dim": info.obs_dim, "embedding_dim": config.embedding_dim, "icvf": cfg.to_dict(config)}
    with store.create("embedding", name, env=info, config=record, seed=seed, parents=[dataset]) as writer:
        save_file({k: v.contiguous() for k, v in result.encoder.state_dict().items()}, str(writer.path("phi.safetensors")))
        result.log.to_csv(writer.path("loss.csv"), index=False)
        writer.metrics.update({"probe_spearman": result.probe_latent, "probe_spearman_raw": result.probe_raw, "final_loss": float(result.log["loss"].iloc[-1])})
    return store.resolve(f"embedding/{name}", "embedding")


def load_encoder(artifact: Artifact, device: torch.device | str = "cpu"):
    from .icvf import Encoder

    record = artifact.config
    icvf_config = cfg.from_dict(cfg.ICVFConfig, record["icvf"]) if record["type"] == "icvf" else None
    encoder = Encoder(record["obs_dim"], icvf_config)
    if icvf_config is not None:
        try:
            encoder.load_state_dict(load_file(str(artifact.file("phi.safetensors"))))
        except (RuntimeError, KeyError) as exc:
            raise LwailError(f"{artifact.ref} holds weights that do not fit its recorded config: {exc}") from None
    return encoder.to(device).requires_grad_(False).eval()


# ------------------------------------------------------------------------------ discriminator
def _expert_pairs(demos: Artifact, episodes_wanted: int) -> tuple[np.ndarray, np.ndarray]:
    from .data import transition_pairs

    episodes, _ = load_demos(demos)
    if episodes_wanted <= 0:
        raise LwailError(f"--expert-episodes must be at least 1, got {episodes_wanted}")
    if episodes_wanted > len(episodes):
        raise LwailError(f"--expert-episodes {episodes_wanted}: {demos.ref} holds only {len(episodes)} episodes")
    return transition_pairs(episodes[:episodes_wanted])


def warmup_discriminator(
    store: Store,
    embedding_ref: str,
    demos_ref: str,
    config: cfg.DiscriminatorConfig,
    expert_episodes: int,
    seed: int,
    name: str | None,
    device: torch.device,
    data_ref: str | None = None,
    on_progress: Callable[[int, float], None] | None = None,
) -> Artifact:
    """Warm f up against true (s, s') pairs of the random policy (data set I) vs expert pairs."""
    from .data import transition_pairs
    from .discriminator import Critic, DiscriminatorTrainer

    embedding = store.resolve(embedding_ref, "embedding")
    demos = store.resolve(demos_ref, "demos")
    info = embedding.env
    require_same_env(info, demos.env, f"demos {demos.ref}")
    dataset = store.resolve(data_ref, "dataset") if data_ref else store.resolve(embedding.manifest["parents"][0]["ref"], "dataset")
    require_same_env(info, dataset.env, f"dataset {dataset.ref}")
    require_positive(config.warmup_steps, "warm-up steps")
    torch.manual_seed(seed)
    encoder = load_encoder(embedding, device)
    states, next_states = transition_pairs(load_dataset(dataset))
    pick = np.random.default_rng(seed).permutation(len(states))[: config.warmup_transitions]
    expert = _features(encoder, *_expert_pairs(demos, expert_episodes), device)
    policy = _features(encoder, states[pick], next_states[pick], device)
    critic = Critic(expert.shape[1], config.hidden).to(device)
    trainer = DiscriminatorTrainer(critic, config)
    chunk = max(1, config.warmup_steps // 50)
    for done in range(0, config.warmup_steps, chunk):
        steps = min(chunk, config.warmup_steps - done)
        wasserstein = trainer.train(expert, policy, steps)
        if on_progress is not None:
            on_progress(done + steps, float(wasserstein))
    name = name or f"{embedding.name}-disc"
    record = {"disc": cfg.to_dict(config), "embedding_type": embedding.config["type"], "input_dim": expert.shape[1], "expert_episodes": expert_episodes}
    with store.create("discriminator", name, env=info, config=record, seed=seed, parents=[embedding, demos, dataset]) as writer:
        save_file({k: v.detach().cpu().contiguous() for k, v in critic.state_dict().items()}, str(writer.path("critic.safetensors")))
        with torch.no_grad():
            writer.metrics.update({
                "wasserstein_estimate": float(wasserstein),
                "reward_expert_mean": float(trainer.reward(expert).mean()),
                "reward_random_mean": float(trainer.reward(policy).mean()),
            })
    return store.resolve(f"discriminator/{name}", "discriminator")


@torch.no_grad()
def _features(encoder, states: np.ndarray, next_states: np.ndarray, device) -> torch.Tensor:
    from .discriminator import transition_features

    return transition_features(encoder, torch.as_tensor(states, device=device), torch.as_tensor(next_states, device=device))


def load_critic(artifact: Artifact, device: torch.device | str = "cpu"):
    from .discriminator import Critic

    critic = Critic(artifact.config["input_dim"], tuple(artifact.config["disc"]["hidden"]))
    try:
        critic.load_state_dict(load_file(str(artifact.file("critic.safetensors"))))
    except (RuntimeError, KeyError) as exc:
        raise LwailError(f"{artifact.ref} holds weights that do not fit its recorded config: {exc}") from None
    return critic.to(device)


# ------------------------------------------------------------------------------ imitation
def imitate(
    store: Store,
    env_id: str,
    demos_ref: str,
    embedding_ref: str,
    disc_ref: str,
    config: cfg.ImitationConfig,
    seed: int,
    name: str | None,
    device: torch.device,
    resume: bool,
    on_progress: Callable[[int, RunState], None] | None = None,
) -> Artifact:
    from .discriminator import DiscriminatorTrainer
    from .imitation import AdversarialReward

    require_positive(config.train.steps, "--steps")
    info = describe_env(env_id)
    demos = store.resolve(demos_ref, "demos")
    embedding = store.resolve(embedding_ref, "embedding")
    disc = store.resolve(disc_ref, "discriminator")
    for artifact in (demos, embedding, disc):
        require_same_env(info, artifact.env, f"{artifact.kind} {artifact.ref}")
    disc_embedding = next(p for p in disc.manifest["parents"] if p["ref"].startswith("embedding/"))
    if disc_embedding["hash"] != embedding.hash:
        raise LwailError(
            f"{disc.ref} was warmed up on {disc_embedding['ref']} ({disc.config['embedding_type']}), "
            f"not on {embedding.ref} ({embedding.config['type']}): warm up a discriminator on this embedding"
        )
    name = name or default_name(env_id, "lwail")
    run = prepare_run(store, "policy", name, resume, config)
    torch.manual_seed(seed)
    encoder = load_encoder(embedding, device)
    expert = _features(encoder, *_expert_pairs(demos, config.expert_episodes), device)
    trainer = DiscriminatorTrainer(load_critic(disc, device), config.disc)
    capacity = min(config.td3.buffer_size, config.train.steps)
    reward_model = AdversarialReward(encoder, trainer, expert, capacity, config.disc)
    agent = TD3(info, config.td3, device)
    buffer = ReplayBuffer(capacity, info.obs_dim, info.act_dim, device)

    reference = reference_for_env(env_id, demos)
    result = train_td3(
        env_id, agent, buffer, config.td3, config.train, seed, reward_model=reward_model,
        reference=reference, resume=run.resume, on_progress=on_progress, on_checkpoint=run.on_checkpoint,
    )
    record = cfg.to_dict(config)
    with store.create("policy", name, env=info, config=record, seed=seed, parents=[demos, embedding, disc], extra={"trained_on": "LWAIL pseudo-reward"}) as writer:
        save_actor(writer.path("actor.safetensors"), agent.actor.state_dict())
        save_file({k: v.detach().cpu().contiguous() for k, v in trainer.critic.state_dict().items()}, str(writer.path("critic.safetensors")))
        _write_history(writer.path("learning_curve.csv"), result)
        _plot_run(writer, result, env_id, reference)
        writer.metrics.update(_final_metrics(result))
        if reference is not None:
            writer.metrics["reference"] = reference.source
    store.clear_checkpoint("policy", name)
    return store.resolve(f"policy/{name}", "policy")


def _plot_run(writer, run: RunState, env_id: str, reference: Reference | None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    history = pd.DataFrame(run.history)
    score = "normalized_score" if reference is not None else "return_mean"
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(history["step"], history[score], marker="o")
    ax.set(xlabel="environment steps", ylabel=score.replace("_", " "), title=f"LWAIL on {env_id}")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(writer.path("learning_curve.png"), dpi=100)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 4))
    points = ax.scatter(history["pseudo_reward_mean"], history["return_mean"], c=history["step"], cmap="viridis")
    fig.colorbar(points, label="environment steps")
    ax.set(xlabel="mean pseudo-reward σ(−f) of recent transitions", ylabel="true return", title="pseudo-reward vs true return")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(writer.path("pseudo_reward_vs_return.png"), dpi=100)
    plt.close(fig)


# ------------------------------------------------------------------------------ quickstart
@dataclass(frozen=True)
class QuickstartPlan:
    collect_transitions: int
    icvf: cfg.ICVFConfig
    imitation: cfg.ImitationConfig


def quickstart_plan(env_id: str, steps: int | None) -> QuickstartPlan:
    """Budgets for the one-command demo: minutes on a 2-core CPU for InvertedPendulum, paper budgets otherwise."""
    bundled_demos_path(env_id)  # refuses an env without bundled demos before any work
    if env_id == "InvertedPendulum-v5":
        steps = steps or 25_000  # TD3 balances after a plateau at returns ~50-100 that lasts 10-20k steps
        return QuickstartPlan(
            collect_transitions=10_000,
            icvf=cfg.ICVFConfig(steps=1_000, log_every=250),
            imitation=cfg.ImitationConfig(
                td3=cfg.TD3Config(random_steps=2_000, learning_starts=2_000),
                train=cfg.TrainConfig(steps=steps, eval_every=max(1, steps // 5), checkpoint_every=steps),
                disc=cfg.DiscriminatorConfig(warmup_steps=500, update_every=2_000),
            ),
        )
    steps = steps or 1_000_000
    return QuickstartPlan(
        collect_transitions=10_000,
        icvf=cfg.ICVFConfig(),
        imitation=cfg.ImitationConfig(train=cfg.TrainConfig(steps=steps, eval_every=min(10_000, steps))),
    )
