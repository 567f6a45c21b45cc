"""Stage: a sweep's report — per task × arm over seeds: mean ± std, the IQM with its 95% stratified-bootstrap
confidence interval, % of our expert's return; across tasks the aggregate IQM and a performance profile; curves.

Two sources of the same report. The store (`lwail report PLAN`): each finished run's policy artifact holds its
learning curve, and its lineage the demonstrations whose mean return is "our expert". Committed files (`lwail report
PLAN --curves DIR`): each run's curve as ``DIR/<plan>_<task>_<arm>_seed<S>.csv`` (how docs/results holds them), our
expert being the bundled one (``experts.json``): the results page is rebuilt without the store. Either way a run
counts once its curve reaches the plan's ``train.steps``; its figures are defined once, in ``learning_curve``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np
import pandas as pd

from .. import statistics
from ..errors import LwailError
from ..evaluation import paper_score
from ..learning_curve import FIGURES, REWARDS, curve_figures, second_half
from ..loaders import policy_curve, read_curve_file
from ..methods import METHODS
from ..plots import plot_arms, plot_critic_by_arm, plot_profile
from .shared import bundled_experts, lineage_demos

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store
    from .sweep_plan import SweepPlan, SweepRun

EXPERT_PCT = "_expert_pct"  # the suffix of a figure given as % of the expert's return instead of normalized
class NothingFinished(LwailError):
    """No run of the plan has reached its last step: there is nothing to report yet (`progress` says where they stand)."""


SCORE = "last_10pct_mean"  # the run's score the IQM, its interval and the performance profile are of ("the last 100k")


@dataclass(frozen=True)
class RunCurve:
    run: SweepRun
    curve: pd.DataFrame
    expert_return: float  # our expert's mean return, the 100% of "% of our expert"
    source: str


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
    runs, summary, across = tables(plan, curves)
    with store.create("report", plan.name, env=None, config=plan.to_dict(), seed=None, parents=policies) as writer:
        runs.to_csv(writer.path("runs.csv"), index=False)
        summary.to_csv(writer.path("summary.csv"), index=False)
        writer.path("summary.md").write_text(markdown(runs, summary, across))
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
    runs, summary, across = tables(plan, curves)
    Path(out).mkdir(parents=True, exist_ok=True)
    written = draw(plan, curves, runs, lambda name: Path(out) / f"{plan.name}_{name}")
    return markdown(runs, summary, across), written


def curve_file_name(plan: SweepPlan, run: SweepRun) -> str:
    return f"{plan.name}_{run.task.lower()}_{run.arm}_seed{run.seed}.csv"


def run_steps(plan: SweepPlan, run: SweepRun) -> int:
    return plan.run_config("imitate", run).train.steps


def _demos_return(store: Store, policy: Artifact) -> float:
    """The mean return of the demonstrations the run imitated: "% of the expert" is the fair yardstick where the
    D4RL reference returns come from older versions of a task (v2 where lwail runs v5)."""
    demos = lineage_demos(store, policy)
    expert_return = None if demos is None else demos.metrics.get("mean_return")
    return float("nan") if expert_return is None else float(expert_return)


# ------------------------------------------------------------------------------ the tables
def tables(plan: SweepPlan, curves: list[RunCurve]) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """One row per run, per task × arm, and per arm across tasks; an arm is one embedding arm and one method."""
    order = {run: index for index, run in enumerate(sorted(plan.runs, key=lambda run: (plan.tasks.index(run.task), plan.arms.index(run.arm), run.seed)))}
    runs = pd.DataFrame([run_row(plan, entry) for entry in sorted(curves, key=lambda entry: order[entry.run])])
    return runs, summarize(runs), across_tasks(runs)


def run_row(plan: SweepPlan, entry: RunCurve) -> dict:
    run, curve, steps = entry.run, entry.curve.copy(), run_steps(plan, entry.run)
    if "normalized_score" not in curve:
        raise LwailError(f"{entry.source} has no normalized scores in its learning curve")
    curve["expert_pct"] = 100 * curve["return_mean"] / entry.expert_return
    later = second_half(curve, steps)
    wall_time = float(curve["wall_time"].iloc[-1]) if "wall_time" in curve else float("nan")
    return {
        "task": run.task, "arm": run.arm, "label": plan.run_label(run), "embedding": plan.embedding_kind(run.kind),
        "method": run.imitation, "seed": run.seed, "source": entry.source, "env_steps": steps, "expert_return": entry.expert_return,
        **curve_figures(curve, steps),
        **{figure + EXPERT_PCT: value for figure, value in curve_figures(curve, steps, "expert_pct").items()},
        "evaluations_after_half": len(later),
        "falls_after_half": int((later["episodes_terminated"] > 0).sum()) if "episodes_terminated" in later else float("nan"),
        "wall_time_s": wall_time, "env_steps_per_s": steps / wall_time,
    }


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per task × arm: mean and std over seeds of each figure; the IQM of the score over seeds with its 95% bootstrap
    interval and the lowest seed's score, each normalized and in % of our expert; the seed count, the mean wall time
    and speed, and the paper's LWAIL figure for the task and embedding kind where it reports one (LWAIL arms only)."""
    grouped = runs.groupby(["task", "arm"], sort=False)
    figures = [*FIGURES, *(figure + EXPERT_PCT for figure in FIGURES)]
    summary = grouped[figures].agg(["mean", "std"])
    summary.columns = [f"{figure}_{stat}" for figure, stat in summary.columns]
    for scale in ("", EXPERT_PCT):
        column = SCORE + scale
        scores = grouped[column].apply(lambda values: values.to_numpy(float))
        summary[f"{column}_iqm"] = [statistics.pooled_iqm([values]) for values in scores]
        summary[f"{column}_ci_low"], summary[f"{column}_ci_high"] = zip(*(statistics.iqm_interval([values]) for values in scores))
        summary[f"{column}_lowest"] = grouped[column].min()
    summary["second_half_min_lowest"] = grouped["second_half_min"].min()
    summary["seeds"] = grouped["seed"].count()
    summary["label"] = grouped["label"].first()
    summary["wall_time_s"] = grouped["wall_time_s"].mean()
    summary["env_steps_per_s"] = grouped["env_steps_per_s"].mean()
    summary["env_steps"] = grouped["env_steps"].first()
    summary["expert_return"] = grouped["expert_return"].first()
    summary["method"] = grouped["method"].first()  # an arm is one embedding and one imitation method
    paper = [(paper_score(task, embedding) if method == "lwail" else None) or (float("nan"), float("nan"))
             for task, embedding, method in zip(summary.index.get_level_values("task"), grouped["embedding"].first(), summary["method"])]
    summary["paper_mean"], summary["paper_std"] = [mean for mean, _ in paper], [std for _, std in paper]
    return summary.reset_index()


def across_tasks(runs: pd.DataFrame) -> pd.DataFrame:
    """Per arm: the IQM of the score over all its runs of all tasks, with its 95% stratified-bootstrap interval (the
    runs of each task resampled on their own), normalized and in % of our expert."""
    rows = []
    for arm, group in runs.groupby("arm", sort=False):
        row = {"arm": arm, "label": group["label"].iloc[0], "tasks": group["task"].nunique(), "runs": len(group)}
        for scale in ("", EXPERT_PCT):
            by_task = [values.to_numpy(float) for _, values in group.groupby("task", sort=False)[SCORE + scale]]
            row[f"iqm{scale}"] = statistics.pooled_iqm(by_task)
            row[f"ci_low{scale}"], row[f"ci_high{scale}"] = statistics.iqm_interval(by_task)
        rows.append(row)
    return pd.DataFrame(rows)


def step_label(steps: int) -> str:
    """1000000 -> 1M, 100000 -> 100k, 600 -> 600."""
    for unit, suffix in ((1_000_000, "M"), (1_000, "k")):
        if steps >= unit and steps % unit == 0:
            return f"{steps // unit}{suffix}"
    return str(steps)


def markdown(runs: pd.DataFrame, summary: pd.DataFrame, across: pd.DataFrame) -> str:
    """Four tables: per task × arm normalized (the paper's figure beside it) and in % of our expert's return, the
    aggregate per arm across tasks, and one row per run."""
    steps = sorted(runs["env_steps"].unique())
    n = int(steps[0]) if len(steps) == 1 else None
    last, end = (f"last {step_label(n // 10)}", f"at {step_label(n)}") if n else ("last 10% of steps", "at the end")
    half = f"after {step_label(n // 2)}" if n else "after half the steps"
    ci = f"IQM over seeds, {last} [{statistics.CONFIDENCE:.0%} CI]"
    notes = (f"*{last}*: mean of the evaluations after step {step_label(n - n // 10) if n else '0.9·N'}; *{end}*: the "
             f"evaluation at the last step; each as mean ± std over seeds. *IQM*: the mean of the middle 50% of the runs "
             f"(of 2 or 3 seeds, their mean); its {statistics.CONFIDENCE:.0%} interval is a stratified percentile bootstrap "
             f"({statistics.RESAMPLES:,} resamples, seed {statistics.BOOTSTRAP_SEED}): over 2 seeds about their range; "
             "none over one seed.")
    normalized = [f"**Normalized score, per task and arm** ({notes})", "",
                  f"| task | arm | seeds | {last} | {ci} | {end} | mean {half} | lowest {half} (any seed) | run time, env-steps/s | paper (1 trajectory, 1M steps) |",
                  "| --- " * 10 + "|"]
    in_pct = ["**% of our expert's return** (the imitated demonstrations' mean), per task and arm", "",
              f"| task | arm | seeds | our expert's return | {last} | {ci} | lowest seed, {last} | {end} | mean {half} |",
              "| --- " * 9 + "|"]
    for row in summary.itertuples(index=False):
        r = row._asdict()
        normalized.append(
            f"| {row.task} | {row.label} | {row.seeds} | {_pm(r, SCORE)} | {_ci(r, SCORE)} | {_pm(r, 'at_end')} | "
            f"{_pm(r, 'second_half_mean')} | {figure_text(row.second_half_min_lowest)} | {row.wall_time_s / 60:.0f} min, "
            f"{row.env_steps_per_s:.0f} | {_pm(r, 'paper')} |")
        pct = SCORE + EXPERT_PCT
        in_pct.append(
            f"| {row.task} | {row.label} | {row.seeds} | {'—' if pd.isna(row.expert_return) else f'{row.expert_return:,.0f}'} | "
            f"{_pm(r, pct)} | {_ci(r, pct)} | {figure_text(r[pct + '_lowest'])} | {_pm(r, 'at_end' + EXPERT_PCT)} | "
            f"{_pm(r, 'second_half_mean' + EXPERT_PCT)} |")
    aggregate = [f"**Across tasks**: the IQM of the {last} over every run of every task, with its {statistics.CONFIDENCE:.0%} "
                 "stratified-bootstrap interval (each task's seeds resampled on their own; — where a task has one seed)", "",
                 f"| arm | tasks | runs | % of our expert: IQM [{statistics.CONFIDENCE:.0%} CI] | normalized: IQM [{statistics.CONFIDENCE:.0%} CI] |",
                 "| --- " * 5 + "|"]
    for row in across.itertuples(index=False):
        r = row._asdict()
        aggregate.append(f"| {row.label} | {row.tasks} | {row.runs} | {_interval(r['iqm_expert_pct'], r['ci_low_expert_pct'], r['ci_high_expert_pct'])} | "
                         f"{_interval(r['iqm'], r['ci_low'], r['ci_high'])} |")
    per_run = ["**Per run**", "",
               f"| task | arm | seed | {last} | {end} | mean {half} | lowest {half} (step) | best (step) | "
               f"evaluations {half} with an episode that fell | % of our expert, {last} | run time, env-steps/s |",
               "| --- " * 11 + "|"]
    for row in runs.itertuples(index=False):
        falls = "—" if pd.isna(row.falls_after_half) else f"{int(row.falls_after_half)} of {row.evaluations_after_half}"
        per_run.append(
            f"| {row.task} | {row.label} | {row.seed} | {figure_text(row.last_10pct_mean)} | {figure_text(row.at_end)} | "
            f"{figure_text(row.second_half_mean)} | {figure_text(row.second_half_min)} ({_step(row.second_half_min_step)}) | "
            f"{figure_text(row.best)} ({_step(row.best_step)}) | {falls} | {figure_text(row.last_10pct_mean_expert_pct)} | "
            f"{row.wall_time_s / 60:.0f} min, {row.env_steps_per_s:.0f} |")
    return "\n\n".join("\n".join(table) for table in (normalized, in_pct, aggregate, per_run)) + "\n"


def figure_text(value: float) -> str:
    """One figure of a table, a dash where there is none."""
    return "—" if pd.isna(value) else f"{value:.1f}"


def _pm(row: dict, figure: str) -> str:
    """``mean ± std``; a dash where there is no figure (demonstrations imported without returns have no % of expert),
    the mean alone where there is no std (one seed)."""
    mean, std = row[f"{figure}_mean"], row[f"{figure}_std"]
    return "—" if pd.isna(mean) else f"{mean:.1f}" if pd.isna(std) else f"{mean:.1f} ± {std:.1f}"


def _ci(row: dict, figure: str) -> str:
    return _interval(row[f"{figure}_iqm"], row[f"{figure}_ci_low"], row[f"{figure}_ci_high"])


def _interval(point: float, low: float, high: float) -> str:
    if pd.isna(point):
        return "—"
    return f"{point:.1f}" + ("" if pd.isna(low) else f" [{low:.1f}, {high:.1f}]")


def _step(step: float) -> str:
    return "—" if pd.isna(step) else f"{step_label(int(step))}"


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
