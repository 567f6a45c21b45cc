"""Stage: a sweep's report — normalized score and % of the expert's return per task × embedding kind, as mean ± std
over seeds, with curves.

Rebuilt from the store alone (`lwail report`): each run's policy artifact holds its learning curve, its
final evaluation (``evals.csv``), env steps and wall time."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

from ..errors import LwailError
from ..evaluation import paper_score
from ..learning_curve import FIGURES, REWARDS, curve_figures
from ..loaders import normalized_evaluations, policy_curve
from ..plots import plot_bands, plot_critic_by_kind
from .shared import lineage_demos

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store
    from .sweep_plan import SweepPlan

EXPERT_PCT = "_expert_pct"  # the suffix of a figure given as % of the expert's return instead of normalized


def report(store: Store, *, plan: SweepPlan) -> Artifact:
    rows, curves, policies = [], [], []
    for run in plan.runs:
        try:
            policy = store.resolve(plan.names(run)["policy"], "policy")
        except LwailError:
            continue  # not finished (yet): the report covers the runs that are
        curve, _ = policy_curve(policy)
        if "normalized_score" not in curve:
            raise LwailError(f"{policy.ref} has no normalized scores in its learning curve")
        steps = policy.metrics["env_steps"]
        final = _final_evaluation(policy)
        expert_return = _expert_return(store, policy)
        curve["expert_pct"] = 100 * curve["return_mean"] / expert_return
        in_pct = curve_figures(curve, steps, None if final is None else 100 * final["return_mean"] / expert_return, "expert_pct")
        rows.append({
            "task": run.task, "kind": run.kind, "embedding": plan.embedding_kind(run.kind), "seed": run.seed, "policy": policy.ref,
            **curve_figures(curve, steps, None if final is None else final["normalized_score"]),
            **{figure + EXPERT_PCT: value for figure, value in in_pct.items()}, "expert_return": expert_return,
            "env_steps": steps, "wall_time_s": policy.metrics["wall_time_s"],
            "env_steps_per_s": steps / policy.metrics["wall_time_s"],
        })
        logged = ["step", "normalized_score", *(column for column in REWARDS if column in curve)]
        curves.append(curve[logged].assign(task=run.task, kind=run.kind, seed=run.seed))
        policies.append(policy)
    if not rows:
        raise LwailError(f"no run of sweep {plan.name} has finished yet")
    runs = pd.DataFrame(rows)
    summary = summarize(runs)
    with store.create("report", plan.name, env=None, config=plan.to_dict(), seed=None, parents=policies) as writer:
        runs.to_csv(writer.path("runs.csv"), index=False)
        summary.to_csv(writer.path("summary.csv"), index=False)
        writer.path("summary.md").write_text(markdown(summary))
        all_curves = pd.concat(curves)
        for task, group in all_curves.groupby("task"):
            plot_bands(group, writer.path(f"curves-{task}.png"), f"{task}: normalized score, mean ± std over seeds")
            if any(column in group for column in REWARDS):
                plot_critic_by_kind(group, writer.path(f"critic-{task}.png"), f"{task}: what the critic f says")
        writer.metrics.update({"runs": len(runs), "runs_planned": len(plan.runs)})
    return writer.artifact


def _final_evaluation(policy: Artifact) -> pd.Series | None:
    evaluations = normalized_evaluations(policy)
    return evaluations.iloc[-1] if len(evaluations) else None


def _expert_return(store: Store, policy: Artifact) -> float:
    """The mean return of the demonstrations the run imitated: "% of the expert" is the fair yardstick where the
    D4RL reference returns come from older versions of a task (v2 where lwail runs v5)."""
    demos = lineage_demos(store, policy)
    expert_return = None if demos is None else demos.metrics.get("mean_return")
    return float("nan") if expert_return is None else float(expert_return)


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per task × kind: mean and std over seeds of each figure, the seed count, the mean wall time and speed, and the
    paper's figure for the task and embedding kind where it reports one."""
    grouped = runs.groupby(["task", "kind"])
    summary = grouped[[*FIGURES, *(figure + EXPERT_PCT for figure in FIGURES)]].agg(["mean", "std"])
    summary.columns = [f"{figure}_{stat}" for figure, stat in summary.columns]
    summary["seeds"] = grouped["seed"].count()
    summary["wall_time_s"] = grouped["wall_time_s"].mean()
    summary["env_steps_per_s"] = grouped["env_steps_per_s"].mean()
    summary = summary.reset_index()
    paper = [paper_score(task, embedding) or (float("nan"), float("nan"))
             for task, embedding in zip(summary["task"], grouped["embedding"].first().to_numpy())]
    summary["paper_mean"], summary["paper_std"] = [mean for mean, _ in paper], [std for _, std in paper]
    return summary


def markdown(summary: pd.DataFrame) -> str:
    """Two tables: the normalized score, with the paper's figure beside it, then the same figures as % of the expert's
    return."""
    tables = []
    for title, suffix in (("normalized score", ""), ("% of the expert's return (the demonstrations' mean)", EXPERT_PCT)):
        paper = " paper: 1 trajectory, 1M steps |" if not suffix else ""
        lines = [f"**{title}**", "",
                 "| task | embedding | final | best | mean, last 10% of steps | mean after half the steps | lowest after half the steps | seeds | wall time | env-steps/s |" + paper,
                 "| --- " * (10 + bool(paper)) + "|"]
        for row in summary.itertuples(index=False):
            cells = [_cell(getattr(row, f + suffix + "_mean"), getattr(row, f + suffix + "_std")) for f in FIGURES]
            paper_cell = f" {_cell(row.paper_mean, row.paper_std)} |" if paper else ""
            lines.append(f"| {row.task} | {row.kind} | {' | '.join(cells)} | {row.seeds} | {row.wall_time_s / 60:.1f} min | {row.env_steps_per_s:.0f} |{paper_cell}")
        tables.append("\n".join(lines))
    return "\n\n".join(tables) + "\n"


def _cell(mean: float, std: float) -> str:
    """``mean ± std``; a dash where there is no figure (demonstrations imported without returns have no % of expert)."""
    return "—" if pd.isna(mean) else f"{mean:.1f} ± {_std(std)}"


def _std(value: float) -> str:
    return "—" if pd.isna(value) else f"{value:.1f}"
