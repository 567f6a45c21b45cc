"""Stage: a sweep's report — per task × arm over seeds: mean ± std, the IQM with its 95% stratified-bootstrap
confidence interval, % of our expert's return; across tasks the aggregate IQM and a performance profile; curves.

Two sources of the same report. The store (`lwail report PLAN`): each finished run's policy artifact holds its
learning curve, and its lineage the demonstrations whose mean return is "our expert". Committed files (`lwail report
PLAN --curves DIR`): each run's curve as ``DIR/<plan>_<task>_<arm>_seed<S>.csv`` (how docs/results holds them), our
expert being the bundled one (``experts.json``): the results page is rebuilt without the store. Either way a run
counts once its curve reaches the plan's ``train.steps``; its figures are defined once, in ``learning_curve``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import pandas as pd

from .. import statistics
from ..errors import LwailError
from ..learning_curve import REWARDS
from ..loaders import policy_curve, read_curve_file
from ..methods import METHODS
from ..plots import plot_arms, plot_critic_by_arm, plot_profile
from .report_tables import EXPERT_PCT, SCORE, RunCurve, markdown, run_steps, step_label, tables
from .shared import bundled_experts, lineage_demos

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store
    from .sweep_plan import SweepPlan, SweepRun


class NothingFinished(LwailError):
    """No run of the plan has reached its last step: there is nothing to report yet (`progress` says where they stand)."""


def report(store: Store, *, plan: SweepPlan) -> Artifact:
    """The report of the plan's finished runs in the store, as a ``report`` artifact (tables and figures)."""
    curves, policies = [], []
    for run in plan.runs:
        try:
            policy = store.resolve(plan.names(run)["policy"], "policy")
        except LwailError:
            continue  # not finished (yet): the report covers the runs that are
        curve, _ = policy_curve(policy)
        curves.append(RunCurve(run, curve, _demos_return(store, policy), policy.ref))
        policies.append(policy)
    if not curves:
        raise NothingFinished(f"no run of sweep {plan.name} has finished yet")
    result = tables(plan, curves)
    runs = result.runs
    with store.create("report", plan.name, env=None, config=plan.to_dict(), seed=None, parents=policies) as writer:
        runs.to_csv(writer.path("runs.csv"), index=False)
        result.summary.to_csv(writer.path("summary.csv"), index=False)
        result.against.to_csv(writer.path("against.csv"), index=False)
        writer.path("summary.md").write_text(markdown(result))
        draw(plan, curves, runs, writer.path)
        writer.metrics.update({"runs": len(runs), "runs_planned": len(plan.runs)})
    return writer.artifact


def report_from_curves(*, plan: SweepPlan, folder: Path, out: Path) -> tuple[str, list[Path]]:
    """The report of the plan's finished runs whose curves ``folder`` holds: its tables (markdown) and the figures
    written into ``out`` as ``<plan>_<name>``."""
    if not Path(folder).is_dir():
        raise LwailError(f"--curves {folder}: no such folder")
    curves = []
    experts = bundled_experts()
    for run in plan.runs:
        path = Path(folder) / curve_file_name(plan, run)
        if path.is_file():
            curve = read_curve_file(path)
            if curve["step"].max() >= run_steps(plan, run):
                curves.append(RunCurve(run, curve, float(experts.get(run.task, {}).get("mean_return", float("nan"))), str(path)))
    if not curves:
        example = curve_file_name(plan, plan.runs[0])
        raise NothingFinished(f"{folder} holds no curve of plan {plan.name} that reached its last step "
                         f"(looked for {plan.name}_<task>_<arm>_seed<S>.csv, e.g. {example})")
    result = tables(plan, curves)
    Path(out).mkdir(parents=True, exist_ok=True)
    written = draw(plan, curves, result.runs, lambda name: Path(out) / f"{plan.name}_{name}")
    return markdown(result), written


def curve_file_name(plan: SweepPlan, run: SweepRun) -> str:
    return f"{plan.name}_{run.task.lower()}_{run.arm}_seed{run.seed}.csv"


def _demos_return(store: Store, policy: Artifact) -> float:
    """The mean return of the demonstrations the run imitated: "% of the expert" is the fair yardstick where the
    D4RL reference returns come from older versions of a task (v2 where lwail runs v5)."""
    demos = lineage_demos(store, policy)
    expert_return = None if demos is None else demos.metrics.get("mean_return")
    return float("nan") if expert_return is None else float(expert_return)


# ------------------------------------------------------------------------------ the figures
def draw(plan: SweepPlan, curves: list[RunCurve], runs: pd.DataFrame, path_for: Callable[[str], Path]) -> list[Path]:
    """Per task, every arm's score over env steps and what its critic says; across tasks, the performance profile.
    Each arm has one colour and one public name in all of them."""
    labels = {entry.run.arm: plan.run_label(entry.run) for entry in curves}
    style = {arm: (label, f"C{plan.arms.index(arm) % 10}") for arm, label in labels.items()}
    rewards = {entry.run.arm: METHODS[entry.run.imitation].reward for entry in curves}
    logged = ["step", "normalized_score", "episodes_terminated", *REWARDS]
    rows = pd.concat([entry.curve[[column for column in logged if column in entry.curve]]
                     .assign(task=entry.run.task, arm=entry.run.arm, seed=entry.run.seed) for entry in curves])
    written = []
    for task, group in rows.groupby("task", sort=False):
        written.append(path_for(f"{task.lower()}_curves.png"))
        plot_arms(group, style, written[-1], f"{task}: normalized score")
        if any(column in group for column in REWARDS):
            written.append(path_for(f"{task.lower()}_critic.png"))
            plot_critic_by_arm(group, style, rewards, written[-1], f"{task}: what each method's reward says")
    score = runs[SCORE + EXPERT_PCT]
    if score.notna().any():
        thresholds = np.linspace(min(0.0, float(score.min())), max(110.0, float(score.max())), 241)
        profiles = {}
        for arm, group in runs.groupby("arm", sort=False):
            by_task = [values.to_numpy(float) for _, values in group.groupby("task", sort=False)[SCORE + EXPERT_PCT]]
            profiles[arm] = (statistics.performance_profile(by_task, thresholds), group["task"].nunique(), len(group))
        written.append(path_for("profile.png"))
        steps = int(runs["env_steps"].iloc[0])
        plot_profile(thresholds, profiles, style, written[-1],
                     f"Performance profile across tasks, each weighing the same\na run's score: its mean of the last "
                     f"{step_label(steps // 10)} in % of our expert's return")
    return written
