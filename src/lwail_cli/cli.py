"""The ``lwail`` command line: parses arguments, shows progress, prints results. Nothing more."""

from __future__ import annotations

import functools
import json
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import typer
from tqdm import tqdm

from . import config as cfg
from . import pipeline
from .artifacts import Store
from .errors import LwailError

app = typer.Typer(
    help="LWAIL: imitate an expert from state-only demonstrations. Stages read and write versioned artifacts.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
expert_app = typer.Typer(help="Train an expert on the true reward and record state-only demonstrations.", no_args_is_help=True)
demos_app = typer.Typer(help="Import state-only demonstrations.", no_args_is_help=True)
app.add_typer(expert_app, name="expert")
app.add_typer(demos_app, name="demos")

_state: dict = {"store": None}

SEED = typer.Option(0, "--seed", help="Random seed.")
NAME = typer.Option(None, "--name", help="Artifact name (default derived from the env id). A rerun writes a new version.")
DEVICE = typer.Option("auto", "--device", help="cpu, cuda, cuda:N or auto.")
SET = typer.Option([], "--set", help="Override any hyper-parameter: section.field=value (see `lwail defaults`). Repeatable.")
RESUME = typer.Option(False, "--resume", help="Continue the killed run of the same name from its last checkpoint.")
STEPS = typer.Option(1_000_000, "--steps", help="Environment steps (one TD3 update each).")
EVAL_EVERY = typer.Option(10_000, "--eval-every", help="Evaluate (10 deterministic episodes) every this many env steps.")
CHECKPOINT_EVERY = typer.Option(50_000, "--checkpoint-every", help="Checkpoint every this many env steps.")


def store() -> Store:
    return Store(_state["store"])


@app.callback()
def main(
    store_dir: Optional[Path] = typer.Option(
        None, "--store", envvar="LWAIL_STORE", help="Artifact store directory (default ./artifacts)."
    ),
    threads: Optional[int] = typer.Option(
        None, "--threads", envvar="LWAIL_THREADS", help="CPU threads for torch (default: all cores; use 1 per job when running several).", min=1
    ),
) -> None:
    _state["store"] = store_dir
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def command(parent: typer.Typer, name: str):
    """Register a command whose LwailError becomes a one-line message and exit code 1."""

    def register(function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                return function(*args, **kwargs)
            except LwailError as exc:
                typer.echo(f"error: {exc}", err=True)
                raise typer.Exit(1) from None
            except KeyboardInterrupt:
                typer.echo("interrupted: the last checkpoint (if any) is kept; rerun with --resume", err=True)
                raise typer.Exit(130) from None

        return parent.command(name)(wrapper)

    return register


class ProgressBar:
    """A tqdm bar that appears on the first progress report, so input errors print alone."""

    def __init__(self, total: int, description: str):
        self.total, self.description, self.bar = total, description, None

    def to(self, done: int, **postfix) -> None:
        if self.bar is None:
            self.bar = tqdm(total=self.total, desc=self.description, unit="step", dynamic_ncols=True, file=sys.stderr, mininterval=0.5)
        self.bar.update(done - self.bar.n)
        if postfix:
            self.bar.set_postfix(postfix, refresh=False)


@contextmanager
def progress_bar(total: int, description: str):
    bar = ProgressBar(total, description)
    try:
        yield bar
    finally:
        if bar.bar is not None:
            bar.bar.close()


def run_progress(bar: ProgressBar):
    """A training-loop callback that moves the bar and shows the latest return and score."""

    def update(step: int, run) -> None:
        shown = {}
        if run.episode_returns:
            shown["ep_return"] = f"{run.episode_returns[-1]:.1f}"
        if run.history:
            last = run.history[-1]
            shown["eval"] = f"{last['return_mean']:.1f}"
            if "normalized_score" in last:
                shown["score"] = f"{last['normalized_score']:.1f}"
        bar.to(step, **shown)

    return update


def say_written(artifact) -> None:
    typer.echo(f"wrote {artifact.ref}  ({artifact.path})")
    if artifact.metrics:
        typer.echo("  " + "  ".join(f"{k}={_fmt(v)}" for k, v in artifact.metrics.items()))


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


# ------------------------------------------------------------------------------ data
@command(app, "collect")
def collect(
    env_id: str = typer.Argument(..., help="Gymnasium environment id, e.g. Hopper-v5."),
    transitions: int = typer.Option(10_000, "--transitions", help="Random-policy transitions to collect."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", help="Import a dataset from the local Minari store (never downloads)."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", help="Import a .npz with 'observations' and 'episode_ends'."),
    seed: int = SEED,
    name: Optional[str] = NAME,
) -> None:
    """Collect state-only data from a uniformly random policy (or import it) as a Minari dataset."""
    if from_minari or from_file:
        artifact = pipeline.import_dataset(store(), env_id, name, from_minari, from_file)
    else:
        pipeline.require_positive(transitions, "--transitions")
        with progress_bar(transitions, f"collect {env_id}") as bar:
            artifact = pipeline.collect(store(), env_id, transitions, seed, name, on_step=lambda n: bar.to(n) if n % 500 == 0 or n == transitions else None)
    say_written(artifact)


# ------------------------------------------------------------------------------ experts & demos
@command(expert_app, "train")
def expert_train(
    env_id: str = typer.Argument(..., help="Gymnasium environment id with a continuous action space."),
    steps: int = STEPS,
    eval_every: int = EVAL_EVERY,
    checkpoint_every: int = CHECKPOINT_EVERY,
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = RESUME,
    overrides: list[str] = SET,
) -> None:
    """Train a TD3 expert on the environment's true reward (the paper's TD3 baseline)."""
    config = cfg.ExpertConfig(train=cfg.TrainConfig(steps=steps, eval_every=eval_every, checkpoint_every=checkpoint_every))
    config = cfg.with_overrides(config, overrides)
    pipeline.require_positive(config.train.steps, "--steps")
    with progress_bar(config.train.steps, f"expert {env_id}") as bar:
        artifact = pipeline.train_expert(store(), env_id, config, seed, name, pipeline.resolve_device(device), resume, run_progress(bar))
    say_written(artifact)


@command(expert_app, "record")
def expert_record(
    policy: str = typer.Argument(..., help="Policy artifact: name, name@vN or a path."),
    episodes: int = typer.Option(10, "--episodes", help="Episodes to record."),
    seed: int = SEED,
    name: Optional[str] = NAME,
) -> None:
    """Roll a policy out and record state-only demonstrations with each episode's return."""
    say_written(pipeline.record_demos(store(), policy, episodes, seed, name))


@command(demos_app, "import")
def demos_import(
    env_id: str = typer.Argument(..., help="Environment the demonstrations come from."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", help="A dataset id in the local Minari store."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", help="A .npz with 'observations', 'episode_ends' (and optional 'returns')."),
    bundled: bool = typer.Option(False, "--bundled", help="The demos shipped with lwail for this env."),
    name: Optional[str] = NAME,
) -> None:
    """Import state-only demonstrations from a local Minari dataset, a .npz, or the bundled set."""
    if bundled:
        say_written(pipeline.import_bundled_demos(store(), env_id, name))
    else:
        say_written(pipeline.import_demos(store(), env_id, name, from_minari, from_file))


# ------------------------------------------------------------------------------ evaluation
@command(app, "eval")
def evaluate(
    policy: str = typer.Argument(..., help="Policy artifact: name, name@vN or a path."),
    episodes: int = typer.Option(10, "--episodes", help="Deterministic evaluation episodes."),
    normalized: bool = typer.Option(False, "--normalized", help="Also print the D4RL-style normalized score."),
    demos: Optional[str] = typer.Option(None, "--demos", help="Demos whose return is the expert reference (default: the policy's own)."),
    seed: int = typer.Option(100, "--seed", help="Seed of the first evaluation episode."),
) -> None:
    """Roll a policy out on the true reward; print mean ± std return (and the normalized score)."""
    result = pipeline.evaluate(store(), policy, episodes, seed, normalized, demos)
    typer.echo(f"{result['policy']}: return {result['return_mean']:.1f} ± {result['return_std']:.1f} over {episodes} episodes")
    if normalized:
        typer.echo(f"normalized score {result['normalized_score']:.1f}  (reference: {result['reference']})")


# ------------------------------------------------------------------------------ the store
@command(app, "ls")
def list_artifacts() -> None:
    """List artifacts: kind, name, versions, env, created, key metric."""
    rows = store().list()
    if not rows:
        typer.echo(f"no artifacts in {store().root}")
        return
    header = ("KIND", "NAME", "VERSIONS", "ENV", "CREATED", "KEY METRIC")
    table = [header]
    for kind, name, versions, manifest in rows:
        metrics = manifest.get("metrics", {})
        key = next((k for k in ("normalized_score", "return_mean", "mean_return", "probe_spearman", "transitions") if k in metrics), None)
        table.append((kind, name, ",".join(f"v{v}" for v in versions), manifest["env"]["id"], manifest["created"][:19], f"{key}={_fmt(metrics[key])}" if key else ""))
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        typer.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())


@command(app, "show")
def show(ref: str = typer.Argument(..., help="kind/name, kind/name@vN or a path.")) -> None:
    """Print one artifact's manifest."""
    kind = ref.split("/")[0] if "/" in ref and not Path(ref).exists() else None
    if kind is None:
        manifest = Path(ref) / "manifest.json"
        if not manifest.is_file():
            raise LwailError(f"give kind/name (e.g. policy/hopper-v5-expert) or an artifact path, not {ref!r}")
        kind = json.loads(manifest.read_text())["kind"]
    typer.echo(json.dumps(store().resolve(ref, kind).manifest, indent=2))


@command(app, "defaults")
def defaults(stage: str = typer.Argument(..., help="expert, icvf, imitate")) -> None:
    """Print a stage's default hyper-parameters (the names --set accepts)."""
    configs = {"expert": cfg.ExpertConfig(), "icvf": cfg.ICVFConfig(), "imitate": cfg.ImitationConfig()}
    if stage not in configs:
        raise LwailError(f"unknown stage {stage!r}; one of {', '.join(configs)}")
    typer.echo(cfg.describe(configs[stage]))


# ------------------------------------------------------------------------------ LWAIL stages
@command(app, "pretrain-icvf")
def pretrain_icvf(
    data: str = typer.Argument(..., help="Dataset artifact (from `lwail collect`)."),
    steps: int = typer.Option(cfg.ICVFConfig.steps, "--steps", help="Gradient steps."),
    batch_size: int = typer.Option(cfg.ICVFConfig.batch_size, "--batch-size"),
    embedding_dim: int = typer.Option(cfg.ICVFConfig.embedding_dim, "--embedding-dim"),
    kind: str = typer.Option("icvf", "--kind", help="icvf, or identity for the paper's no-embedding ablation."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    overrides: list[str] = SET,
) -> None:
    """Pre-train the ICVF state embedding φ on state-only data and report its quality probe."""
    if kind not in ("icvf", "identity"):
        raise LwailError(f"--kind must be icvf or identity, not {kind!r}")
    config = cfg.with_overrides(cfg.ICVFConfig(steps=steps, batch_size=batch_size, embedding_dim=embedding_dim), overrides)
    if kind == "identity":
        artifact = pipeline.pretrain_icvf(store(), data, config, seed, name, pipeline.resolve_device(device), identity=True)
    else:
        pipeline.require_positive(config.steps, "--steps")
        pipeline.require_positive(config.batch_size, "--batch-size")
        with progress_bar(config.steps, "pretrain-icvf") as bar:

            artifact = pipeline.pretrain_icvf(store(), data, config, seed, name, pipeline.resolve_device(device), identity=False, on_progress=lambda n, loss: bar.to(n, loss=f"{loss:.4f}"))
    say_written(artifact)


@command(app, "warmup-disc")
def warmup_disc(
    embedding: str = typer.Argument(..., help="Embedding artifact (from `lwail pretrain-icvf`)."),
    demos: str = typer.Argument(..., help="Demos artifact."),
    data: Optional[str] = typer.Option(None, "--data", help="Random-policy dataset (default: the one the embedding was trained on)."),
    expert_episodes: int = typer.Option(1, "--expert-episodes", help="Expert trajectories to use."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    overrides: list[str] = SET,
) -> None:
    """Warm the discriminator f up: expert pairs vs the random policy's true (s, s') pairs."""
    config = cfg.with_overrides(cfg.DiscriminatorConfig(), overrides)
    pipeline.require_positive(config.warmup_steps, "warmup_steps")
    with progress_bar(config.warmup_steps, "warmup-disc") as bar:
        artifact = pipeline.warmup_discriminator(
            store(), embedding, demos, config, expert_episodes, seed, name, pipeline.resolve_device(device), data,
            lambda n, wasserstein: bar.to(n, wasserstein=f"{wasserstein:.3f}"),
        )
    say_written(artifact)


@command(app, "imitate")
def imitate(
    env_id: str = typer.Argument(..., help="Environment to imitate in."),
    demos: str = typer.Option(..., "--demos", help="Demos artifact."),
    embedding: str = typer.Option(..., "--embedding", help="Embedding artifact."),
    disc: str = typer.Option(..., "--disc", help="Warmed-up discriminator artifact."),
    steps: int = STEPS,
    expert_episodes: int = typer.Option(1, "--expert-episodes", help="Expert trajectories to imitate."),
    eval_every: int = EVAL_EVERY,
    checkpoint_every: int = CHECKPOINT_EVERY,
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = RESUME,
    overrides: list[str] = SET,
) -> None:
    """Imitate with TD3 on the LWAIL pseudo-reward σ(−f(φ(s), φ(s')))."""
    config = cfg.ImitationConfig(
        train=cfg.TrainConfig(steps=steps, eval_every=eval_every, checkpoint_every=checkpoint_every),
        expert_episodes=expert_episodes,
    )
    config = cfg.with_overrides(config, overrides)
    pipeline.require_positive(config.train.steps, "--steps")
    with progress_bar(config.train.steps, f"imitate {env_id}") as bar:
        artifact = pipeline.imitate(store(), env_id, demos, embedding, disc, config, seed, name, pipeline.resolve_device(device), resume, run_progress(bar))
    say_written(artifact)


@command(app, "quickstart")
def quickstart(
    env_id: str = typer.Option("InvertedPendulum-v5", "--env", help="A task with bundled demos."),
    steps: Optional[int] = typer.Option(None, "--steps", help="Imitation env steps (default: short for InvertedPendulum, the paper's 1M otherwise)."),
    seed: int = SEED,
    device: str = DEVICE,
) -> None:
    """The whole chain on bundled demos: collect → pretrain-icvf → warmup-disc → imitate → eval --normalized."""
    plan = pipeline.quickstart_plan(env_id, steps)
    resolved = pipeline.resolve_device(device)
    s = store()
    typer.echo(f"quickstart on {env_id} into store {s.root}")
    demos = pipeline.import_bundled_demos(s, env_id, None)
    say_written(demos)
    with progress_bar(plan.collect_transitions, "1/4 collect") as bar:
        data = pipeline.collect(s, env_id, plan.collect_transitions, seed, None, on_step=lambda n: bar.to(n) if n % 500 == 0 else None)
    say_written(data)
    with progress_bar(plan.icvf.steps, "2/4 pretrain-icvf") as bar:
        embedding = pipeline.pretrain_icvf(s, data.ref, plan.icvf, seed, None, resolved, identity=False, on_progress=lambda n, loss: bar.to(n))
    say_written(embedding)
    with progress_bar(plan.imitation.disc.warmup_steps, "3/4 warmup-disc") as bar:
        disc = pipeline.warmup_discriminator(s, embedding.ref, demos.ref, plan.imitation.disc, 1, seed, None, resolved, None, lambda n, w: bar.to(n))
    say_written(disc)
    with progress_bar(plan.imitation.train.steps, "4/4 imitate") as bar:
        policy = pipeline.imitate(s, env_id, demos.ref, embedding.ref, disc.ref, plan.imitation, seed, None, resolved, False, run_progress(bar))
    say_written(policy)
    result = pipeline.evaluate(s, policy.ref, 10, 100, True, None)
    typer.echo(f"{policy.ref}: return {result['return_mean']:.1f} ± {result['return_std']:.1f}; "
               f"normalized score {result['normalized_score']:.1f} ({result['reference']})")
