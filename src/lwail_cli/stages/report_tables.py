"""The report's tables: a run's figures (``learning_curve.curve_figures``), per task × arm over seeds, per arm across
tasks, and the plan's first arm against each other arm; then the same as markdown, as `lwail report` prints them and
docs/results holds them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import pandas as pd

from .. import statistics
from ..errors import LwailError
from ..evaluation import paper_score
from ..learning_curve import FIGURES, curve_figures, second_half

if TYPE_CHECKING:
    from .sweep_plan import SweepPlan, SweepRun

EXPERT_PCT = "_expert_pct"  # the suffix of a figure given as % of the expert's return instead of normalized
SCORE = "last_10pct_mean"  # the run's score the IQM, its interval and the performance profile are of ("the last 100k")


@dataclass(frozen=True)
class RunCurve:
    run: SweepRun
    curve: pd.DataFrame
    expert_return: float  # our expert's mean return, the 100% of "% of our expert"
    source: str


def run_steps(plan: SweepPlan, run: SweepRun) -> int:
    return plan.run_config("imitate", run).train.steps


class Tables(NamedTuple):
    runs: pd.DataFrame  # one row per run
    summary: pd.DataFrame  # per task × arm over seeds
    across: pd.DataFrame  # per arm across tasks
    against: pd.DataFrame  # the plan's first arm against each other arm, per task and across tasks


def tables(plan: SweepPlan, curves: list[RunCurve]) -> Tables:
    """One row per run, per task × arm, per arm across tasks, and the first arm against each other; an arm is one
    embedding arm and one method."""
    order = {run: index for index, run in enumerate(sorted(plan.runs, key=lambda run: (plan.tasks.index(run.task), plan.arms.index(run.arm), run.seed)))}
    runs = pd.DataFrame([run_row(plan, entry) for entry in sorted(curves, key=lambda entry: order[entry.run])])
    return Tables(runs, summarize(runs), across_tasks(runs), against_first(runs, plan.arms[0]))


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



def against_first(runs: pd.DataFrame, first: str) -> pd.DataFrame:
    """The plan's first arm against each other arm, on each task where both have runs: the difference of their mean
    scores over seeds (first − other), normalized and in % of our expert, with Welch's interval, and P(first > other)
    with its interval; over those tasks (two or more), P(first > other) averaged, each task weighing the same."""
    rows, mine = [], runs[runs["arm"] == first]
    first_label = mine["label"].iloc[0] if len(mine) else first
    for other, theirs in runs[runs["arm"] != first].groupby("arm", sort=False):
        pairs = []
        for task, their_runs in theirs.groupby("task", sort=False):
            my_runs = mine[mine["task"] == task]
            if my_runs.empty:
                continue
            row = {"task": task, "first": first_label, "arm": other, "label": their_runs["label"].iloc[0], "seeds_first": len(my_runs), "seeds_other": len(their_runs)}
            scores = {scale: (my_runs[SCORE + scale].to_numpy(float), their_runs[SCORE + scale].to_numpy(float)) for scale in ("", EXPERT_PCT)}
            for scale, (x, y) in scores.items():
                row[f"difference{scale}"] = x.mean() - y.mean()
                row[f"difference_ci_low{scale}"], row[f"difference_ci_high{scale}"] = statistics.mean_difference_interval(x, y)
            pairs.append(scores[""])  # P is the same on either scale: both order the runs by return
            row["p_first_higher"], row["p_ci_low"], row["p_ci_high"] = statistics.mean_probability_of_improvement(pairs[-1:])
            rows.append(row)
        if len(pairs) > 1:
            p, low, high = statistics.mean_probability_of_improvement(pairs)
            rows.append({"task": "all tasks", "first": first_label, "arm": other, "label": theirs["label"].iloc[0], "seeds_first": sum(len(x) for x, _ in pairs),
                         "seeds_other": sum(len(y) for _, y in pairs), "p_first_higher": p, "p_ci_low": low, "p_ci_high": high})
    return pd.DataFrame(rows)


def step_label(steps: int) -> str:
    """1000000 -> 1M, 100000 -> 100k, 600 -> 600."""
    for unit, suffix in ((1_000_000, "M"), (1_000, "k")):
        if steps >= unit and steps % unit == 0:
            return f"{steps // unit}{suffix}"
    return str(steps)


def markdown(report: Tables) -> str:
    """Per task × arm normalized (the paper's figure beside it) and in % of our expert's return, the aggregate per arm
    across tasks, the first arm against each other (where the plan has two arms on a task), and one row per run."""
    runs, summary, across = report.runs, report.summary, report.across
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
    against = _against_table(report.against, last) if not report.against.empty else []
    return "\n\n".join("\n".join(table) for table in (normalized, in_pct, aggregate, against, per_run) if table) + "\n"


def _against_table(against: pd.DataFrame, last: str) -> list[str]:
    level = f"{statistics.CONFIDENCE:.0%}"
    lines = [f"**{against['first'].iloc[0]} against each other arm** (per task: the difference of the {last} means over seeds, first − "
             f"other, with Welch's {level} t-interval, which allows for how few seeds there are; *separates*: that "
             f"interval excludes 0. *P(first > other)*: the share of seed pairs in which the first arm's run scored "
             f"higher, ties counting half (the probability of improvement of Agarwal et al. 2021), with its {level} "
             "stratified-bootstrap interval, as coarse as its few pairs; over all tasks its mean, each task weighing the "
             "same, which *separates* when its interval excludes 0.5; — where an arm has one seed)", "",
             f"| task | against | seeds | difference, normalized [{level} CI] | difference, % of our expert [{level} CI] | "
             f"P(first > other) [{level} CI] | separates |", "| --- " * 7 + "|"]
    for row in against.to_dict("records"):
        overall = row["task"] == "all tasks"
        low, high = (row["p_ci_low"], row["p_ci_high"]) if overall else (row["difference_ci_low"], row["difference_ci_high"])
        middle = 0.5 if overall else 0.0
        separates = "—" if pd.isna(low) else "first higher" if low > middle else "first lower" if high < middle else "no"
        differences = ["—" if overall else _signed(row, scale) for scale in ("", EXPERT_PCT)]
        lines.append(f"| {row['task']} | {row['label']} | {row['seeds_first']} vs {row['seeds_other']} | {differences[0]} | "
                     f"{differences[1]} | {row['p_first_higher']:.2f}{_bracket(row['p_ci_low'], row['p_ci_high'], '.2f')} | {separates} |")
    return lines


def _signed(row: dict, scale: str) -> str:
    """A difference with its sign and interval; a dash where there is none (demonstrations without returns)."""
    value = row[f"difference{scale}"]
    return "—" if pd.isna(value) else f"{value:+.1f}" + _bracket(row[f"difference_ci_low{scale}"], row[f"difference_ci_high{scale}"], ".1f")


def _bracket(low: float, high: float, spec: str) -> str:
    return "" if pd.isna(low) else f" [{low:{spec}}, {high:{spec}}]"


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
    return f"{point:.1f}" + _bracket(low, high, ".1f")


def _step(step: float) -> str:
    return "—" if pd.isna(step) else f"{step_label(int(step))}"

