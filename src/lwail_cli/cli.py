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


def store() -> Store:
    return Store(_state["store"])


@app.callback()
def main(
    store_dir: Optional[Path] = typer.Option(
        None, "--store", envvar="LWAIL_STORE", help="Artifact store directory (default ./artifacts)."
    ),
) -> None:
    _state["store"] = store_dir


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


@contextmanager
def progress_bar(total: int, description: str):
    bar = tqdm(total=total, desc=description, unit="step", dynamic_ncols=True, file=sys.stderr, mininterval=0.5)
    try:
        yield bar
    finally:
        bar.close()


def run_progress(bar: tqdm):
    """A training-loop callback that moves the bar and shows the latest return and score."""

    def update(step: int, run) -> None:
        bar.update(step - bar.n)
        shown = {}
        if run.episode_returns:
            shown["ep_return"] = f"{run.episode_returns[-1]:.1f}"
        if run.history:
            last = run.history[-1]
            shown["eval"] = f"{last['return_mean']:.1f}"
            if "normalized_score" in last:
                shown["score"] = f"{last['normalized_score']:.1f}"
        bar.set_postfix(shown, refresh=False)

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
            artifact = pipeline.collect(store(), env_id, transitions, seed, name, on_step=lambda n: bar.update(n - bar.n) if n % 500 == 0 or n == transitions else None)
    say_written(artifact)


# ------------------------------------------------------------------------------ experts & demos
@command(expert_app, "train")
def expert_train(
    env_id: str = typer.Argument(..., help="Gymnasium environment id with a continuous action space."),
    steps: int = typer.Option(1_000_000, "--steps", help="Environment steps (one TD3 update each)."),
    eval_every: int = typer.Option(10_000, "--eval-every", help="Evaluate every this many env steps."),
    checkpoint_every: int = typer.Option(50_000, "--checkpoint-every", help="Checkpoint every this many env steps."),
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
