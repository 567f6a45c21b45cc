"""Stage: a sweep's unfinished runs so far, which `lwail report` prints after the finished runs' tables (or alone,
while none has finished): how far each run's learning curve has got, its latest evaluation, the mean of its
evaluations over the last 10% of the plan's steps it has run (as wide a window as "the last 100k"), that mean in % of
our expert's return, its best evaluation and the early probe of a saturated critic.

From the store, the curve a running or killed run keeps in the run area; from committed files, a run's curve
``DIR/<plan>_<task>_<arm>_seed<S>.csv`` short of its last step, or ``..._seed<S>_to<N>k.csv`` (docs/results holds a
running curve so, N its last step in thousands; the furthest one counts). These are where runs stand, not results:
no figure of them enters the report's statistics."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ..errors import LwailError
from ..learning_curve import LAST_FRACTION, SATURATION_STEP, WASSERSTEIN, saturated_critic
from ..loaders import live_curve, read_curve_file
from .report import curve_file_name
from .report_tables import RunCurve, figure_text, run_steps, step_label
from .shared import bundled_experts

if TYPE_CHECKING:
    from ..artifacts import Store
    from .sweep_plan import SweepPlan, SweepRun


def unfinished_in_store(store: Store, *, plan: SweepPlan) -> list[RunCurve]:
    """The plan's runs with a curve in the store's run area and no finished policy artifact."""
    partial = []
    for run in plan.runs:
        name = plan.names(run)["policy"]
        if _finished(store, name):
            continue  # in the report's tables
        live = live_curve(store, name)
        curve = None if live is None else read_curve_file(live)
        if curve is not None and not curve.empty:
            partial.append(RunCurve(run, curve, _demos_return(store, plan, run), name))
    return partial


def unfinished_in_folder(*, plan: SweepPlan, folder: Path) -> list[RunCurve]:
    """The plan's runs whose curve in ``folder`` stops short of the plan's steps (the furthest file of each)."""
    experts, partial = bundled_experts(), []
    for run in plan.runs:
        finished = Path(folder) / curve_file_name(plan, run)
        running = sorted(Path(folder).glob(f"{finished.stem}_to*k.csv"), key=_thousands)
        path = finished if finished.is_file() else running[-1] if running else None
        if path is None:
            continue
        curve = read_curve_file(path)
        if not curve.empty and curve["step"].max() < run_steps(plan, run):
            partial.append(RunCurve(run, curve, float(experts.get(run.task, {}).get("mean_return", float("nan"))), str(path)))
    return partial


def _finished(store: Store, name: str) -> bool:
    try:
        store.resolve(name, "policy")
    except LwailError:
        return False
    return True


def _thousands(path: Path) -> int:
    found = re.search(r"_to(\d+)k\.csv$", path.name)
    return int(found.group(1)) if found else -1


def _demos_return(store: Store, plan: SweepPlan, run: SweepRun) -> float:
    try:
        demos = store.resolve(plan.demos_name(run.task), "demos")
    except LwailError:
        return float("nan")
    return float(demos.metrics.get("mean_return", float("nan")))


def row(plan: SweepPlan, entry: RunCurve) -> dict:
    """Where one unfinished run stands."""
    curve, steps = entry.curve, run_steps(plan, entry.run)
    reached = int(curve["step"].iloc[-1])
    score = curve["normalized_score"] if "normalized_score" in curve else pd.Series(float("nan"), index=curve.index)
    recent = score[curve["step"] > reached - LAST_FRACTION * steps]
    best = score.idxmax() if score.notna().any() else None
    probe = "—" if WASSERSTEIN not in curve or reached < SATURATION_STEP else "saturated" if saturated_critic(curve) else "not saturated"
    return {
        "task": entry.run.task, "label": plan.run_label(entry.run), "seed": entry.run.seed, "reached": reached, "steps": steps,
        "latest": float(score.iloc[-1]), "recent_mean": float(recent.mean()),
        "recent_expert_pct": float(100 * curve["return_mean"][recent.index].mean() / entry.expert_return),
        "best": float("nan") if best is None else float(score[best]), "best_step": float("nan") if best is None else float(curve["step"][best]),
        "probe": probe, "source": Path(entry.source).name,  # a file's name, or a run's in the store
    }


def markdown(plan: SweepPlan, partial: list[RunCurve]) -> str:
    """One row per unfinished run, in the plan's order."""
    order = {run: index for index, run in enumerate(plan.runs)}
    rows = [row(plan, entry) for entry in sorted(partial, key=lambda entry: order[entry.run])]
    window = step_label(int(LAST_FRACTION * rows[0]["steps"])) if len({r["steps"] for r in rows}) == 1 else "10% of the steps"
    lines = [f"**Unfinished runs so far** (where each stands, not a result: none enters the report's statistics; *recent*: the mean "
             f"of the evaluations over the last {window} it has run; *critic at 150k*: the early probe (docs/algorithm.md) of a saturated critic)", "",
             "| task | arm | seed | curve to | latest | recent | recent, % of our expert | best (step) | critic at 150k | curve or run |",
             "| --- " * 10 + "|"]
    for r in rows:
        lines.append(f"| {r['task']} | {r['label']} | {r['seed']} | {step_label(r['reached'])} of {step_label(r['steps'])} | "
                     f"{figure_text(r['latest'])} | {figure_text(r['recent_mean'])} | {figure_text(r['recent_expert_pct'])} | "
                     f"{figure_text(r['best'])} ({'—' if pd.isna(r['best_step']) else step_label(int(r['best_step']))}) | {r['probe']} | `{r['source']}` |")
    return "\n".join(lines) + "\n"

