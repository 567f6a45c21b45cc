"""The commands that read results: eval, curve, the chain in one go (quickstart) or as a grid (sweep), a sweep's
report, and export to another toolkit."""

from __future__ import annotations

import json
import shlex
from pathlib import Path
from typing import Optional

import typer

from .. import config as cfg
from .. import learning_curve
from ..errors import LwailError
from ..loaders import curve_figure_path, read_curve
from ..stages import curve as curve_stage
from ..stages import evaluate as evaluate_stage
from ..stages import export as export_stage
from ..stages import online as online_stage
from ..stages import progress
from ..stages import quickstart as quickstart_stage
from ..stages import report as report_stage
from ..stages import reward_map as reward_map_stage
from ..stages import sweep as sweep_stage
from ..stages.declaration import PLAN_STAGES
from ..stages.sweep_plan import grid_lines, plan_from_dict, read_plan, select_runs
from ..stages.shared import resolve_device
from .app import DEVICE, SEED, VIDEO, app, command, lwail_line, progress_bar, say_written, store, warn


@command(app, "eval", config=cfg.EvalConfig)
def evaluate(
    policy: str = typer.Argument(..., metavar="POLICY", help="Policy artifact: name, name@vN or a path."),
    normalized: bool = typer.Option(False, "--normalized", help=(
        "Also print the normalized score 100·(R − R_random)/(R_expert − R_random). R_random and R_expert: for Hopper, "
        "HalfCheetah, Walker2d and Ant (AntNoContactForces too), whatever the version (-v5 included), D4RL's reference "
        "returns, measured on the -v2 tasks; for other tasks a Minari dataset's ref_min/max_score, else the demos' mean "
        "return (or the bundled expert's) against a random policy's return measured on 10 episodes; for PointMazeUMaze, "
        "PointMazeMedium and PointMazeLarge D4RL's maze2d(-dense) references, with the success rate and the % of our "
        "expert's return. The line printed names the reference used.")),
    demos: Optional[str] = typer.Option(None, "--demos", metavar="REF", help="With --normalized: demos whose return is the expert reference (default: the policy's own)."),
    video: Optional[Path] = VIDEO,
    *,
    config: cfg.EvalConfig,
) -> None:
    """Roll a policy out on the true reward; print mean ± std return (and the normalized score)."""
    result = evaluate_stage.evaluate(store(), policy_ref=policy, config=config, normalized=normalized, demos_ref=demos, video_dir=video)
    _say_evaluation(result)
    for path in result["videos"]:
        typer.echo(f"wrote {path}")


def _say_evaluation(result: dict) -> None:
    noise = f" (start noise {result['start_noise']:g})" if result.get("start_noise") else ""
    typer.echo(f"{result['policy']}: return {result['return_mean']:.1f} ± {result['return_std']:.1f} over {result['episodes']} episodes{noise}")
    if "success_rate" in result:
        typer.echo(f"success rate {100 * result['success_rate']:.0f}%  (goal reached within its radius at some step)")
    if "normalized_score" in result:
        typer.echo(f"normalized score {result['normalized_score']:.1f}  (reference: {result['reference']})")
    if "expert_percent" in result:
        typer.echo(f"{result['expert_percent']:.1f}% of our expert's return")
    if result.get("not_logged"):
        warn([f"not appended to evals.csv: {result['not_logged']}"])


@command(app, "curve")
def curve(
    refs: list[str] = typer.Argument(..., metavar="RUN...", help="A run's --name (running, killed or finished) or a policy artifact ref; several draw one panel each."),
    out: Optional[Path] = typer.Option(None, "--out", metavar="FILE", help="PNG to write (default: curve.png beside the run's curve, in its policy artifact or, while it runs, in the run area; several runs: curve+<the others>.png beside the first's)."),
) -> None:
    """Print and plot a run's learning curve and critic diagnostics, also while it runs or after a kill; with several
    runs (e.g. the experts of three tasks), each one's table and summary, and one figure of their returns side by side."""
    histories = {}
    for ref in refs:
        history, source = read_curve(store(), ref=ref)
        typer.echo(source)
        shown = history[[column for column in learning_curve.TABLE if column in history]]
        typer.echo(shown.to_string(index=False, float_format=lambda value: f"{value:.3f}"))
        for line in curve_stage.summary_lines(history):
            typer.echo(line)
        histories[ref] = history
    path = out or curve_figure_path(store(), refs=refs)
    if len(histories) == 1:
        typer.echo(f"wrote {curve_stage.plot_curve(history, path, refs[0], curve_stage.reward_of(store(), refs[0]))}")
    else:
        typer.echo(f"wrote {curve_stage.plot_curves(histories, path)}")


@command(app, "reward-map")
def reward_map(
    critic: str = typer.Argument(..., metavar="CRITIC", help="A PointMaze discriminator (from `warmup-disc`) or an `imitate` policy, whose kept critic is drawn."),
    per_cell: int = typer.Option(20, "--per-cell", metavar="N", help="Grid points per cell side."),
    out: Optional[Path] = typer.Option(None, "--out", metavar="FILE", help="PNG to write (default: reward-map.png beside the critic's artifact)."),
) -> None:
    """Draw the learned reward σ(−f(φ(s), φ(s))) over the maze's (x, y) at zero velocity, walls drawn: the paper's figure."""
    typer.echo(f"wrote {reward_map_stage.reward_map(store(), critic_ref=critic, per_cell=per_cell, out=out)}")


@command(app, "quickstart")
def quickstart(
    env_id: str = typer.Option(quickstart_stage.QUICK_ENV, "--env", metavar="ENV_ID", help="A task with bundled demos."),
    steps: Optional[int] = typer.Option(None, "--steps", metavar="N", help="--set imitate:train.steps=N: imitation env steps (default: the task's preset, else the paper's 1M)."),
    overrides: list[str] = typer.Option([], "--set", metavar="STAGE:KEY=VALUE", help=(
        f"Override a stage's hyper-parameter over the task's preset, e.g. imitate:td3.actor_lr=1e-4 (stages: {', '.join(PLAN_STAGES)}; "
        "their settings: `lwail defaults STAGE`). Repeatable, each key once.")),
    seed: int = SEED,
    device: str = DEVICE,
) -> None:
    """The whole chain on bundled demos: collect → pretrain-icvf → warmup-disc → imitate → eval --normalized. Each
    stage runs its defaults under the task's preset (InvertedPendulum's: minutes on a CPU; `lwail defaults
    quickstart` prints it), then --set."""
    configs = quickstart_stage.quickstart_configs(env_id, [*overrides, *([f"imitate:train.steps={steps}"] if steps is not None else [])])
    warn(online_stage.budget_warnings(configs["imitate"]))
    s = store()
    typer.echo(f"quickstart on {env_id} into store {s.root}")
    result = quickstart_stage.quickstart(
        s, env_id=env_id, configs=configs, seed=seed, device=resolve_device(device), progress=progress_bar, on_written=say_written
    )
    _say_evaluation(result)
    typer.echo(f"\nevery artifact above is in {s.root} (`lwail ls` lists them). Next:")
    for why, line in next_steps(result["policy"], env_id, s.root):
        typer.echo(f"  # {why}\n  {line}")


def next_steps(policy_ref: str, env_id: str, store_root: Path) -> list[tuple[str, str]]:
    """What to run after quickstart, each (why, command line): the run's curve, its policy in Python, another task."""
    other = next(task for task in ("Hopper-v5", "Walker2d-v5") if task != env_id)
    # double-quoted literals (json.dumps: valid Python), so that the shell's single quotes around them need no escapes
    python = f"from lwail_cli import load_policy; print(load_policy({json.dumps(policy_ref)}, store={json.dumps(str(store_root))}))"
    return [
        ("the run's learning curve: a table, and a figure beside the policy", lwail_line(f"curve {policy_ref}")),
        ("the policy in Python: .predict(obs) as in Stable-Baselines3 (docs/usage.md#python)", f"python -c {shlex.quote(python)}"),
        ("the chain on another task (--steps: a shorter run); your own task: the README's stages",
         lwail_line(f"quickstart --env {other} --steps 200000")),
    ]


@command(app, "sweep")
def sweep(
    plan_file: Path = typer.Argument(..., metavar="PLAN", help="A plan (TOML): name, tasks, seeds, embeddings, methods, [set] overrides per stage and [variants.NAME] arms; see plans/."),
    address: Optional[str] = typer.Option(None, "--address", metavar="HOST:PORT", help="Attach to a running Ray cluster (its nodes must share this store's path); without it the sweep starts its own, whatever RAY_ADDRESS says."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Print the grid (each run, its arm's settings) and stop: nothing runs."),
    only: Optional[list[str]] = typer.Option(None, "--only", metavar="TASK[:SEED[:ARM]]", help="Run only the runs this picks (repeatable; * for any part, e.g. Walker2d-v5:0 or '*:1:identity'); they keep the names and fingerprints the whole plan gives them."),
) -> None:
    """Run a grid of tasks × seeds × embeddings × methods (× an [axis]) on Ray (one CPU each), skipping finished stages;
    then report."""
    plan = read_plan(plan_file)
    runs = select_runs(plan, only or [])
    chosen = "" if len(runs) == len(plan.runs) else f" of {len(plan.runs)}"
    if dry_run:
        data_sets, phis = {(run.task, run.seed) for run in runs}, {plan.phi_of(run) for run in runs}
        typer.echo(f"sweep {plan.name}: {len(runs)}{chosen} runs on {len(data_sets)} data sets I and {len(phis)} φs")
        typer.echo("\n".join(grid_lines(plan, runs)))
        return
    s = store()
    typer.echo(f"sweep {plan.name}: {len(runs)}{chosen} runs into store {s.root.resolve()}")

    def show(status: dict[str, str]) -> None:
        width = max(map(len, status))
        typer.echo("\n".join(f"  {label.ljust(width)}  {line}" for label, line in status.items()) + "\n")

    failures = sweep_stage.run_sweep(s, plan=plan, runs=runs, address=address, on_status=show)
    _say_report(report_stage.report(s, plan=plan))
    if failures:
        raise LwailError(f"{len(failures)} of {len(runs)} runs failed ({'; '.join(failures)}); rerun the sweep to retry them")


@command(app, "report")
def report(
    sweep_ref: str = typer.Argument(..., metavar="PLAN_OR_SWEEP", help="A plan file, or the name of a sweep that has a report."),
    curves: Optional[Path] = typer.Option(None, "--curves", metavar="DIR", help="Read each run's curve from DIR/<plan>_<task>_<arm>_seed<S>.csv (as docs/results holds them) instead of the store; needs the plan file."),
    out: Optional[Path] = typer.Option(None, "--out", metavar="DIR", help="With --curves: the folder for the figures (default: the --curves folder)."),
) -> None:
    """A sweep's report: per task and arm over seeds mean ± std, IQM with a 95% bootstrap interval and % of our
    expert; across tasks the IQM and a performance profile; the plan's first arm against each other (the difference
    with Welch's 95% interval, the probability of improvement); curves; then where each unfinished run stands. From
    the store, or with --curves from committed curve files alone (a running run's as <...>_seed<S>_to<N>k.csv)."""
    names_a_file = Path(sweep_ref).is_file() or sweep_ref.endswith(".toml")  # a missing plan file gets read_plan's error
    if curves is not None:
        if not names_a_file:
            raise LwailError(f"--curves reads no store: give the plan file (e.g. plans/paper-table.toml), not {sweep_ref!r}")
        plan = read_plan(Path(sweep_ref))
        unfinished = progress.unfinished_in_folder(plan=plan, folder=curves)
        try:
            table, written = report_stage.report_from_curves(plan=plan, folder=curves, out=out or curves)
        except report_stage.NothingFinished as nothing:
            if not unfinished:
                raise
            table, written = f"{nothing}\n", []
        for path in written:
            typer.echo(f"wrote {path}")
        typer.echo(table)
        if unfinished:
            typer.echo(progress.markdown(plan, unfinished))
        return
    s = store()
    if names_a_file:
        plan = read_plan(Path(sweep_ref))
    else:
        plan = plan_from_dict(s.resolve(sweep_ref, "report").config, f"report {sweep_ref}")
    unfinished = progress.unfinished_in_store(s, plan=plan)
    try:
        _say_report(report_stage.report(s, plan=plan))
    except report_stage.NothingFinished as nothing:
        if not unfinished:
            raise
        typer.echo(f"{nothing}: no report written")
    if unfinished:
        typer.echo(progress.markdown(plan, unfinished))


def _say_report(artifact) -> None:
    say_written(artifact)
    typer.echo(artifact.file("summary.md").read_text())


@command(app, "export")
def export(
    policy: str = typer.Argument(..., metavar="POLICY", help="Policy artifact: name, name@vN or a path."),
    out: Path = typer.Option(..., "--out", metavar="FILE", help="File to write (model.zip for --format sb3)."),
    fmt: str = typer.Option("sb3", "--format", metavar="FORMAT", help="sb3: a Stable-Baselines3 TD3 model.zip (TD3.load(path).predict)."),
) -> None:
    """Write a policy for another toolkit: the actor as an SB3 TD3 model (its critic freshly initialised)."""
    typer.echo(f"wrote {export_stage.export_policy(store(), policy_ref=policy, fmt=fmt, out=out)}")

