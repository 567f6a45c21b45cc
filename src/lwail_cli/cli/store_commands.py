"""The commands that look into the store and the settings, and pause a run in it: ls, show, verify, defaults, pause."""

from __future__ import annotations

import json
import textwrap
from typing import List, Optional

import typer

from .. import config as cfg
from .. import glossary
from ..errors import LwailError
from ..names import closest
from ..stages.declaration import presets, table_lines
from .app import app, command, fmt, store


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
        table.append((kind, name, ",".join(f"v{v}" for v in versions), (manifest["env"] or {"id": "-"})["id"], manifest["created"][:19], f"{key}={fmt(metrics[key])}" if key else ""))
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        typer.echo("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())


@command(app, "show")
def show(ref: str = typer.Argument(..., metavar="REF", help="name, name@vN (either kind/-prefixed where two kinds share the name) or a path.")) -> None:
    """Print one artifact's manifest (JSON, on stdout) and what its metrics mean (on stderr)."""
    artifact = store().resolve_any(ref)
    typer.echo(json.dumps(artifact.manifest, indent=2))
    explained = {metric: glossary.meaning(metric) for metric in artifact.metrics if glossary.meaning(metric)}
    if explained:
        typer.echo("\nwhat its metrics mean (docs/usage.md#what-the-metrics-mean):", err=True)
        width = max(map(len, explained))
        for metric, text in explained.items():
            typer.echo(textwrap.fill(text, width=80, initial_indent=f"  {metric.ljust(width)}  ", subsequent_indent=" " * (width + 4)), err=True)


@command(app, "verify")
def verify(ref: Optional[str] = typer.Argument(None, metavar="REF", help="name, name@vN, kind/name@vN or a path (default: every artifact in the store).")) -> None:
    """Re-hash every file and manifest of one artifact, or of the whole store; exit 1 if anything is damaged."""
    results = store().verify(ref)
    for path, problem in results:
        typer.echo(f"ok       {path}" if problem is None else f"DAMAGED  {path}: {problem}")
    damaged = sum(problem is not None for _, problem in results)
    typer.echo(f"{len(results)} artifact versions checked, {damaged} damaged")
    if damaged:
        raise typer.Exit(1)


@command(app, "pause")
def pause(names: List[str] = typer.Argument(..., metavar="RUN...", help="The name of an `imitate`, `expert train` or `pretrain-icvf` run in progress (as `lwail ls` will list its artifact), e.g. a sweep's <sweep>-<task>-s<seed>-<arm>.")) -> None:
    """Ask runs in progress to checkpoint and stop (within ~100 env steps, or one pre-training step), to free the
    machine without losing their work: the same command with --resume (a sweep: the same `lwail sweep`) continues each
    bit for bit. SIGTERM to a run's process does the same."""
    for name in names:
        for kind in store().runs.request_pause(name):
            typer.echo(f"asked {kind}/{name} to checkpoint and stop")


@command(app, "defaults")
def defaults(stage: Optional[str] = typer.Argument(None, metavar="STAGE", help=f"One of {', '.join(cfg.STAGES)}, or quickstart: its presets (default: all stages).")) -> None:
    """Print a stage's hyper-parameters with their defaults and meaning (the names --set accepts), or the settings
    quickstart gives each task over them."""
    if stage == "quickstart":
        typer.echo("# quickstart: per task, what it sets over the stages' defaults (as a sweep plan's [set]); its --set goes on top")
        for task, table in presets().items():
            typer.echo("\n".join([f"[{task}]", *table_lines(table)]))
        return
    if stage is not None and stage not in cfg.STAGES:
        raise LwailError(f"unknown stage {stage!r}; {closest(stage, [*cfg.STAGES, 'quickstart'], 'stages')}")
    for name, config_type in cfg.STAGES.items():
        if stage in (None, name):
            typer.echo(f"# {name}\n{cfg.describe(config_type())}")
