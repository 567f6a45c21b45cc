"""The ``lwail`` command line: parses arguments, shows progress, prints results. Nothing more."""

from __future__ import annotations

import functools
import json
import re
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import typer
from tqdm import tqdm

from . import __version__
from . import config as cfg
from .artifacts import Store, check_name
from .errors import LwailError
from .stages import collect as collect_stage
from .stages import curve as curve_stage
from .stages import demos as demos_stage
from .stages import embed as embed_stage
from .stages import evaluate as evaluate_stage
from .stages import expert as expert_stage
from .stages import export as export_stage
from .stages import imitate as imitate_stage
from .stages import quickstart as quickstart_stage
from .stages import report as report_stage
from .stages import sweep as sweep_stage
from .stages import warmup as warmup_stage
from .stages.shared import resolve_device

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

_state: dict = {"store": None, "tensorboard": None}

# the largest seed every consumer takes: torch takes up to 2**64 - 1, numpy's SeedSequence any, but numpy's legacy
# np.random.seed (which a user's environment may call with it) only up to 2**32 - 1
MAX_SEED = 2**32 - 1
SEED = typer.Option(0, "--seed", help=f"Random seed (0 to {MAX_SEED}).", min=0, max=MAX_SEED)
NAME = typer.Option(None, "--name", help="Artifact name (default derived from the env id). A rerun writes a new version.")
DEVICE = typer.Option("auto", "--device", help="cpu, cuda, cuda:N or auto.")
SET = typer.Option([], "--set", help="Override any hyper-parameter: field=value or section.field=value (see `lwail defaults`). Repeatable, "
                   "each key once, applied together (their order never matters). Lists: 64,64 or [64, 64]; [] is no hidden layer (a linear map).")
RESUME = typer.Option(False, "--resume", help="Continue the killed run of the same name from its last checkpoint; --steps (the checkpoint's step ends it there), --eval-every, --checkpoint-every, train.eval_episodes and train.average_tau may differ.")
STEPS = typer.Option(cfg.TrainConfig.steps, "--steps", help="Environment steps (one TD3 update each).")
EVAL_EVERY = typer.Option(cfg.TrainConfig.eval_every, "--eval-every", help="Evaluate the deterministic actor every this many env steps.")
CHECKPOINT_EVERY = typer.Option(cfg.TrainConfig.checkpoint_every, "--checkpoint-every", help="Checkpoint every this many env steps.")
VIDEO = typer.Option(None, "--video", help="Write an MP4 of each episode into this folder (headless; needs lwail[video]).")
EXPERT_EPISODES = typer.Option(1, "--expert-episodes", help="Expert trajectories to use.")


def store() -> Store:
    return Store(_state["store"])


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"lwail {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    store_dir: Optional[Path] = typer.Option(None, "--store", envvar="LWAIL_STORE", help="Artifact store directory (default ./artifacts)."),
    threads: Optional[int] = typer.Option(
        None, "--threads", envvar="LWAIL_THREADS", help="CPU threads for torch (default: all cores; use 1 per job when running several).", min=1
    ),
    tensorboard: Optional[Path] = typer.Option(
        None, "--tensorboard", envvar="LWAIL_TENSORBOARD", help="Also write every long stage's figures as TensorBoard scalars under this folder."
    ),
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True, help="Print the version and exit."),
) -> None:
    _state["store"] = store_dir
    _state["tensorboard"] = tensorboard
    if threads is not None:
        import torch

        torch.set_num_threads(threads)


def command(parent: typer.Typer, name: str):
    """Register a command whose LwailError (or OSError from the file system) becomes one line and exit code 1.
    A --name is checked before anything runs (an empty one would otherwise fall back to the default silently)."""

    def register(function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                if kwargs.get("name") is not None:
                    check_name(kwargs["name"])
                return function(*args, **kwargs)
            except LwailError as exc:
                typer.echo(f"error: {' '.join(str(exc).splitlines())}", err=True)  # one line, whatever an env's exception said
                raise typer.Exit(1) from None
            except OSError as exc:  # the machine, not lwail: a store that is a file, read-only, a full disk
                where = f" ({exc.filename})" if exc.filename else ""
                typer.echo(f"error: {exc.strerror or exc}{where}; writes are atomic, so nothing was half-written", err=True)
                raise typer.Exit(1) from None
            except KeyboardInterrupt:
                typer.echo("interrupted: the last checkpoint (if any) is kept; rerun with --resume", err=True)
                raise typer.Exit(130) from None

        return parent.command(name)(wrapper)

    return register


@contextmanager
def progress_bar(description: str, total: int):
    """A tqdm bar that appears on the first report (so input errors print alone); yields the stages' callback.
    With --tensorboard, every figure reported (an evaluation's whole CSV row included) is also a scalar."""
    bars: list[tqdm] = []
    scalars = tensorboard_writer(description)

    def report(done: int, shown: dict) -> None:
        if not bars:
            # steps done before the bar appears (a resumed run's, or the first report's) are not counted in its rate
            bars.append(tqdm(total=total, initial=done, desc=description, unit="step", dynamic_ncols=True, file=sys.stderr, mininterval=0.5))
        bars[0].update(done - bars[0].n)
        if shown:
            bars[0].set_postfix({key: _fmt(value) for key, value in shown.items() if "/" not in key}, refresh=False)
        if scalars is not None:
            for key, value in shown.items():
                if isinstance(value, (int, float)) and not isinstance(value, bool):
                    scalars.add_scalar(key, value, done)

    try:
        yield report
    finally:
        if bars:
            bars[0].close()
        if scalars is not None:
            scalars.close()


def tensorboard_writer(description: str):
    """A SummaryWriter for one stage's run (None without --tensorboard)."""
    if _state["tensorboard"] is None:
        return None
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        raise LwailError('--tensorboard needs the tensorboard package: pip install "lwail[tensorboard]"') from None
    run = re.sub(r"[^A-Za-z0-9._-]+", "_", description).strip("_")
    return SummaryWriter(log_dir=str(Path(_state["tensorboard"]) / f"{run}-{time.strftime('%Y%m%d-%H%M%S')}"))


def say_written(artifact) -> None:
    typer.echo(f"wrote {artifact.ref}  ({artifact.path})")
    if artifact.metrics:
        typer.echo("  " + "  ".join(f"{k}={_fmt(v)}" for k, v in artifact.metrics.items()))


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _train_config(steps: int, eval_every: int, checkpoint_every: int) -> cfg.TrainConfig:
    return cfg.TrainConfig(steps=steps, eval_every=eval_every, checkpoint_every=checkpoint_every)


# ------------------------------------------------------------------------------ data
@command(app, "collect")
def collect(
    env_id: str = typer.Argument(..., help="Gymnasium environment id, e.g. Hopper-v5."),
    transitions: int = typer.Option(cfg.CollectConfig.transitions, "--transitions", help="Random-policy transitions to collect."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", help="Import a dataset from the local Minari store (never downloads)."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", help="Import a .npz with 'observations' and 'episode_ends'."),
    seed: int = SEED,
    name: Optional[str] = NAME,
) -> None:
    """Collect state-only data from a uniformly random policy (or import it) as a Minari dataset."""
    if from_minari and from_file:
        raise LwailError("give one source: --from-minari or --from-file (neither: collect from a random policy)")
    if from_minari or from_file:
        artifact = collect_stage.import_dataset(store(), env_id=env_id, name=name, minari_id=from_minari, npz=from_file)
    else:
        config = cfg.CollectConfig(transitions=transitions)
        with progress_bar(f"collect {env_id}", config.transitions) as report:
            artifact = collect_stage.collect(store(), env_id=env_id, config=config, seed=seed, name=name, on_progress=report)
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
    config = cfg.with_overrides(cfg.ExpertConfig(train=_train_config(steps, eval_every, checkpoint_every)), overrides)
    with progress_bar(f"expert {env_id}", config.train.steps) as report:
        artifact = expert_stage.train_expert(
            store(), env_id=env_id, config=config, seed=seed, name=name, device=resolve_device(device), resume=resume, on_progress=report
        )
    say_written(artifact)


@command(expert_app, "record")
def expert_record(
    policy: str = typer.Argument(..., help="Policy artifact: name, name@vN or a path."),
    episodes: int = typer.Option(cfg.RecordConfig.episodes, "--episodes", help="Episodes to record."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    video: Optional[Path] = VIDEO,
) -> None:
    """Roll a policy out and record state-only demonstrations with each episode's return."""
    config = cfg.RecordConfig(episodes=episodes)
    say_written(demos_stage.record_demos(store(), policy_ref=policy, config=config, seed=seed, name=name, video_dir=video))


@command(demos_app, "import")
def demos_import(
    env_id: str = typer.Argument(..., help="Environment the demonstrations come from."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", help="A dataset id in the local Minari store."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", help="A .npz with 'observations', 'episode_ends' (and optional 'returns')."),
    bundled: bool = typer.Option(False, "--bundled", help="The demos shipped with lwail for this env."),
    from_imitation: Optional[Path] = typer.Option(
        None, "--from-imitation", help="Trajectories saved by the imitation library (imitation.data.serialize.save: a folder, or its older .npz)."),
    from_sb3: Optional[Path] = typer.Option(None, "--from-sb3", help="Roll out a Stable-Baselines3 model.zip (read as data, never unpickled)."),
    episodes: int = typer.Option(cfg.RecordConfig.episodes, "--episodes", help="Episodes to roll out (--from-sb3)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
) -> None:
    """Import state-only demonstrations: a local Minari dataset, a .npz, imitation's trajectories, an SB3 model's
    rollouts, or the bundled set."""
    if sum(map(bool, (bundled, from_sb3, from_minari, from_file, from_imitation))) > 1:
        raise LwailError("give one source: --bundled, --from-sb3, --from-minari, --from-file or --from-imitation")
    if bundled:
        say_written(demos_stage.import_bundled_demos(store(), env_id=env_id, name=name))
    elif from_sb3 is not None:
        config = cfg.RecordConfig(episodes=episodes)
        say_written(demos_stage.import_sb3_demos(store(), env_id=env_id, model=from_sb3, config=config, seed=seed, name=name))
    else:
        say_written(demos_stage.import_demos(store(), env_id=env_id, name=name, minari_id=from_minari, npz=from_file, imitation=from_imitation))


# ------------------------------------------------------------------------------ LWAIL stages
@command(app, "pretrain-icvf")
def pretrain_icvf(
    data: str = typer.Argument(..., help="Dataset artifact (from `lwail collect`)."),
    steps: int = typer.Option(cfg.ICVFConfig.steps, "--steps", help="Gradient steps."),
    batch_size: int = typer.Option(cfg.ICVFConfig.batch_size, "--batch-size", help="Tuples per gradient step."),
    embedding_dim: int = typer.Option(cfg.ICVFConfig.embedding_dim, "--embedding-dim", help="Dimension of φ(s)."),
    kind: str = typer.Option(cfg.EmbedConfig.kind, "--kind", help="icvf, or identity for the paper's no-embedding ablation."),
    demos: Optional[str] = typer.Option(None, "--demos", help="Expert demos: also probe expert-vs-random separation and progress in φ (recommended)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = typer.Option(False, "--resume", help="Continue the killed pre-training of the same name from its last checkpoint."),
    overrides: list[str] = SET,
) -> None:
    """Pre-train the ICVF state embedding φ on state-only data and report its quality probe."""
    icvf = cfg.ICVFConfig(steps=steps, batch_size=batch_size, embedding_dim=embedding_dim)
    config = cfg.with_overrides(cfg.EmbedConfig(kind=kind, icvf=icvf), overrides)
    total = config.icvf.steps if config.kind == "icvf" else 0
    with progress_bar("pretrain-icvf", total) as report:
        artifact = embed_stage.embed(
            store(), data_ref=data, config=config, seed=seed, name=name, device=resolve_device(device), demos_ref=demos, on_progress=report,
            resume=resume,
        )
    say_written(artifact)


@command(app, "warmup-disc")
def warmup_disc(
    embedding: str = typer.Argument(..., help="Embedding artifact (from `lwail pretrain-icvf`)."),
    demos: str = typer.Argument(..., help="Demos artifact."),
    data: Optional[str] = typer.Option(None, "--data", help="Random-policy dataset (default: the one the embedding was trained on)."),
    expert_episodes: int = EXPERT_EPISODES,
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    overrides: list[str] = SET,
) -> None:
    """Warm the discriminator f up: expert pairs vs the random policy's true (s, s') pairs."""
    config = cfg.with_overrides(cfg.WarmupConfig(expert_episodes=expert_episodes), overrides)
    with progress_bar("warmup-disc", config.steps) as report:
        artifact = warmup_stage.warmup(
            store(), embedding_ref=embedding, demos_ref=demos, config=config, seed=seed, name=name,
            device=resolve_device(device), data_ref=data, on_progress=report,
        )
    say_written(artifact)


@command(app, "imitate")
def imitate(
    env_id: str = typer.Argument(..., help="Environment to imitate in."),
    demos: str = typer.Option(..., "--demos", help="Demos artifact."),
    embedding: str = typer.Option(..., "--embedding", help="Embedding artifact."),
    disc: str = typer.Option(..., "--disc", help="Warmed-up discriminator artifact (f keeps the loss it was warmed up with)."),
    steps: int = STEPS,
    expert_episodes: int = EXPERT_EPISODES,
    eval_every: int = EVAL_EVERY,
    checkpoint_every: int = CHECKPOINT_EVERY,
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = RESUME,
    overrides: list[str] = SET,
) -> None:
    """Imitate with TD3 on the LWAIL pseudo-reward σ(−f(φ(s), φ(s')))."""
    config = cfg.ImitationConfig(train=_train_config(steps, eval_every, checkpoint_every), expert_episodes=expert_episodes)
    config = cfg.with_overrides(config, overrides)
    with progress_bar(f"imitate {env_id}", config.train.steps) as report:
        artifact = imitate_stage.imitate(
            store(), env_id=env_id, demos_ref=demos, embedding_ref=embedding, disc_ref=disc, config=config, seed=seed,
            name=name, device=resolve_device(device), resume=resume, on_progress=report,
        )
    say_written(artifact)


# ------------------------------------------------------------------------------ evaluation
@command(app, "eval")
def evaluate(
    policy: str = typer.Argument(..., help="Policy artifact: name, name@vN or a path."),
    episodes: int = typer.Option(cfg.EvalConfig.episodes, "--episodes", help="Deterministic evaluation episodes."),
    normalized: bool = typer.Option(False, "--normalized", help="Also print the D4RL-style normalized score."),
    demos: Optional[str] = typer.Option(None, "--demos", help="With --normalized: demos whose return is the expert reference (default: the policy's own)."),
    seed: int = typer.Option(cfg.EvalConfig.seed, "--seed", help="Seed of the first evaluation episode.", min=0),
    video: Optional[Path] = VIDEO,
) -> None:
    """Roll a policy out on the true reward; print mean ± std return (and the normalized score)."""
    config = cfg.EvalConfig(episodes=episodes, seed=seed)
    result = evaluate_stage.evaluate(store(), policy_ref=policy, config=config, normalized=normalized, demos_ref=demos, video_dir=video)
    _say_evaluation(result)
    for path in result["videos"]:
        typer.echo(f"wrote {path}")


def _say_evaluation(result: dict) -> None:
    typer.echo(f"{result['policy']}: return {result['return_mean']:.1f} ± {result['return_std']:.1f} over {result['episodes']} episodes")
    if "normalized_score" in result:
        typer.echo(f"normalized score {result['normalized_score']:.1f}  (reference: {result['reference']})")
    if result.get("not_logged"):
        typer.echo(f"warning: not appended to evals.csv: {result['not_logged']}", err=True)


CURVE_COLUMNS = ("step", "wall_time", "return_mean", "return_std", "normalized_score",
                 *(f"{name}_normalized_score" for name in cfg.POLICY_NETWORKS), "reward_expert_mean", "pseudo_reward_mean",
                 "reward_random_mean", "wasserstein_estimate", "pseudo_return_spearman", "episodes_terminated")


@command(app, "curve")
def curve(
    refs: list[str] = typer.Argument(..., help="A run's --name (running, killed or finished) or a policy artifact ref; several draw one panel each."),
    out: Optional[Path] = typer.Option(None, "--out", help="PNG to write (default: <ref>-curve.png in this folder, refs joined by '+')."),
) -> None:
    """Print and plot a run's learning curve and critic diagnostics, also while it runs or after a kill; with several
    runs (e.g. the experts of three tasks), each one's table and summary, and one figure of their returns side by side."""
    histories = {}
    for ref in refs:
        history, source = curve_stage.read_curve(store(), ref=ref)
        typer.echo(source)
        shown = history[[column for column in CURVE_COLUMNS if column in history]]
        typer.echo(shown.to_string(index=False, float_format=lambda value: f"{value:.3f}"))
        for line in curve_stage.summary_lines(history):
            typer.echo(line)
        histories[ref] = history
    path = out or Path(re.sub(r"[^A-Za-z0-9._+-]", "_", "+".join(refs)) + "-curve.png")
    if len(histories) == 1:
        typer.echo(f"wrote {curve_stage.plot_curve(history, path, refs[0])}")
    else:
        typer.echo(f"wrote {curve_stage.plot_curves(histories, path)}")


@command(app, "quickstart")
def quickstart(
    env_id: str = typer.Option(quickstart_stage.QUICK_ENV, "--env", help="A task with bundled demos."),
    steps: Optional[int] = typer.Option(None, "--steps", help="Imitation env steps (default: short for InvertedPendulum, the paper's 1M otherwise)."),
    seed: int = SEED,
    device: str = DEVICE,
) -> None:
    """The whole chain on bundled demos: collect → pretrain-icvf → warmup-disc → imitate → eval --normalized."""
    plan = quickstart_stage.quickstart_plan(env_id, steps)
    s = store()
    typer.echo(f"quickstart on {env_id} into store {s.root}")
    result = quickstart_stage.quickstart(
        s, env_id=env_id, plan=plan, seed=seed, device=resolve_device(device), progress=progress_bar, on_written=say_written
    )
    _say_evaluation(result)


@command(app, "sweep")
def sweep(
    plan_file: Path = typer.Argument(..., help="A plan (TOML): name, tasks, seeds, embeddings, [set] overrides per stage and [variants.NAME] arms; see plans/."),
    address: Optional[str] = typer.Option(None, "--address", help="Attach to a running Ray cluster (its nodes must share this store's path)."),
) -> None:
    """Run a grid of tasks × seeds × embeddings on Ray (one CPU each), skipping finished stages; then report."""
    plan = sweep_stage.read_plan(plan_file)
    s = store()
    typer.echo(f"sweep {plan.name}: {len(plan.runs)} runs into store {s.root.resolve()}")

    def show(status: dict[str, str]) -> None:
        width = max(map(len, status))
        typer.echo("\n".join(f"  {label.ljust(width)}  {line}" for label, line in status.items()) + "\n")

    failures = sweep_stage.run_sweep(s, plan=plan, address=address, on_status=show)
    _say_report(report_stage.report(s, plan=plan))
    if failures:
        raise LwailError(f"{len(failures)} of {len(plan.runs)} runs failed ({'; '.join(failures)}); rerun the sweep to retry them")


@command(app, "report")
def report(sweep_ref: str = typer.Argument(..., help="A plan file, or the name of a sweep that has a report.")) -> None:
    """Rebuild a sweep's report (mean ± std over seeds, curves) from the store."""
    s = store()
    if Path(sweep_ref).is_file():
        plan = sweep_stage.read_plan(Path(sweep_ref))
    else:
        plan = sweep_stage.plan_from_dict(s.resolve(sweep_ref, "report").config, f"report {sweep_ref}")
    _say_report(report_stage.report(s, plan=plan))


def _say_report(artifact) -> None:
    say_written(artifact)
    typer.echo(artifact.file("summary.md").read_text())


@command(app, "export")
def export(
    policy: str = typer.Argument(..., help="Policy artifact: name, name@vN or a path."),
    out: Path = typer.Option(..., "--out", help="File to write (model.zip for --format sb3)."),
    fmt: str = typer.Option("sb3", "--format", help="sb3: a Stable-Baselines3 TD3 model.zip (TD3.load(path).predict)."),
) -> None:
    """Write a policy for another toolkit: the actor as an SB3 TD3 model (its critic freshly initialised)."""
    typer.echo(f"wrote {export_stage.export_policy(store(), policy_ref=policy, fmt=fmt, out=out)}")


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
        if manifest is None:
            table.append((kind, name, ",".join(f"v{v}" for v in versions), "DAMAGED", "", "run `lwail verify` for details"))
            continue
        metrics = manifest.get("metrics", {})
        key = next((k for k in ("normalized_score", "return_mean", "mean_return", "probe_spearman", "transitions") if k in metrics), None)
        table.append((kind, name, ",".join(f"v{v}" for v in versions), (manifest["env"] or {"id": "-"})["id"], manifest["created"][:19], f"{key}={_fmt(metrics[key])}" if key else ""))
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        typer.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())


@command(app, "show")
def show(ref: str = typer.Argument(..., help="kind/name, kind/name@vN or a path.")) -> None:
    """Print one artifact's manifest."""
    typer.echo(json.dumps(store().resolve_any(ref).manifest, indent=2))


@command(app, "verify")
def verify(ref: Optional[str] = typer.Argument(None, help="kind/name[@vN] or a path (default: every artifact in the store).")) -> None:
    """Re-hash every file and manifest of one artifact, or of the whole store; exit 1 if anything is damaged."""
    results = store().verify(ref)
    for path, problem in results:
        typer.echo(f"ok       {path}" if problem is None else f"DAMAGED  {path}: {problem}")
    damaged = sum(problem is not None for _, problem in results)
    typer.echo(f"{len(results)} artifact versions checked, {damaged} damaged")
    if damaged:
        raise typer.Exit(1)


@command(app, "defaults")
def defaults(stage: Optional[str] = typer.Argument(None, help=f"One of {', '.join(cfg.STAGES)} (default: all).")) -> None:
    """Print a stage's hyper-parameters with their defaults and meaning (the names --set accepts)."""
    if stage is not None and stage not in cfg.STAGES:
        raise LwailError(f"unknown stage {stage!r}; one of {', '.join(cfg.STAGES)}")
    for name, config_type in cfg.STAGES.items():
        if stage in (None, name):
            typer.echo(f"# {name}\n{cfg.describe(config_type())}")
