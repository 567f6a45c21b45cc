"""Pictures of a run's learning curve and diagnostics, and of a sweep's bands (used by `imitate`, `curve` and `report`)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from .config import POLICY_NETWORKS
from .learning_curve import PSEUDO_REWARD, REWARDS


def _pyplot():
    """matplotlib's pyplot on the file-only Agg backend (no display needed), imported only when a figure is drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    _pyplot().close(fig)


def score_column(history: pd.DataFrame) -> str:
    if "normalized_score" in history and history["normalized_score"].notna().any():
        return "normalized_score"
    return "return_mean"


GENERIC_REWARD = "reward"  # the legend's word for a run whose method is not known (a run still going or killed)


def plot_run(history: pd.DataFrame, curve_path: Path, scatter_path: Path | None, title: str, reward: str = GENERIC_REWARD) -> None:
    """The score against env steps above the method's rewards (``reward``: its formula, methods.base.Method.reward);
    and, when asked, that reward vs the true return."""
    plt = _pyplot()
    score = score_column(history)
    rewards = [column for column in REWARDS if column in history]
    fig, axes = plt.subplots(2 if rewards else 1, 1, figsize=(7, 6 if rewards else 4), sharex=True, squeeze=False)
    top = axes[0, 0]
    top.plot(history["step"], history[score], marker="o", markersize=3, label="kept policy")
    others = [(name, f"{name}_{score}") for name in POLICY_NETWORKS if f"{name}_{score}" in history]
    for name, column in others:  # the network train.policy does not name, evaluated on the same episodes
        top.plot(history["step"], history[column], linestyle="--", alpha=0.7, label=f"{name} network (not kept)")
    if others:
        top.legend(fontsize=8)
    top.set(ylabel=score.replace("_", " "), title=title)
    top.grid(alpha=0.3)
    if rewards:
        bottom = axes[1, 0]
        for column in rewards:
            bottom.plot(history["step"], history[column], label=f"{reward} {REWARDS[column]}")
        bounded = all(history[column].max() <= 1 for column in rewards)  # σ(−f) is; GAIfO's and PWIL's rewards are not
        bottom.set(ylabel="reward", ylim=(0, 1) if bounded else (0, None))
        bottom.legend(fontsize=8)
        bottom.grid(alpha=0.3)
    axes[-1, 0].set(xlabel="environment steps")
    _save(fig, curve_path)
    if scatter_path is None or PSEUDO_REWARD not in history:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    points = ax.scatter(history[PSEUDO_REWARD], history["return_mean"], c=history["step"], cmap="viridis")
    fig.colorbar(points, label="environment steps")
    ax.set(xlabel=f"mean {reward} of recent transitions", ylabel="true return", title=f"{reward} vs true return")
    ax.grid(alpha=0.3)
    _save(fig, scatter_path)


def plot_side_by_side(curves: dict[str, pd.DataFrame], path: Path) -> None:
    """One panel per run (e.g. the experts of several tasks): the true return of the kept network and of each other
    network logged, with a cross at every evaluation where an episode of the kept network ended early (a fall)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(curves), figsize=(5 * len(curves), 3.8), squeeze=False)
    for ax, (title, history) in zip(axes[0], curves.items()):
        ax.plot(history["step"], history["return_mean"], marker="o", markersize=2, label="kept network")
        for name in POLICY_NETWORKS:
            if f"{name}_return_mean" in history:
                ax.plot(history["step"], history[f"{name}_return_mean"], linestyle="--", alpha=0.6, label=f"{name} network (not kept)")
        if "episodes_terminated" in history:
            fell = history[history["episodes_terminated"] > 0]
            ax.scatter(fell["step"], fell["return_mean"], marker="x", color="red", zorder=3, label="an episode ended early")
        ax.set(title=title, xlabel="environment steps", ylabel="true return (mean of the evaluation episodes)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    _save(fig, path)


def _steps_axis(ax) -> None:
    """Env steps as 200k, 1M rather than in units of 1e6."""
    from matplotlib.ticker import EngFormatter

    ax.xaxis.set_major_formatter(EngFormatter(sep=""))


def seeds_phrase(seeds: int) -> str:
    return "1 seed" if seeds == 1 else f"mean over {seeds} seeds"


def plot_arms(curves: pd.DataFrame, style: dict[str, tuple[str, str]], path: Path, title: str) -> None:
    """The normalized score against env steps, one colour per arm (``style``: arm -> public name, colour): each
    seed's curve thin, with a cross where an evaluation episode fell, and the mean over seeds thick. The title says
    how many seeds each mean is of."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    counts = {}
    for arm, (label, colour) in style.items():
        group = curves[curves["arm"] == arm]
        if group.empty:
            continue
        counts[arm] = group["seed"].nunique()
        for _, seed in group.groupby("seed"):
            if counts[arm] > 1:
                ax.plot(seed["step"], seed["normalized_score"], color=colour, linewidth=0.8, alpha=0.35)
            if "episodes_terminated" in seed:
                fell = seed[seed["episodes_terminated"] > 0]
                ax.scatter(fell["step"], fell["normalized_score"], marker="x", s=14, color=colour, alpha=0.6)
        mean = group.groupby("step")["normalized_score"].mean()
        ax.plot(mean.index, mean, color=colour, linewidth=2 if counts[arm] > 1 else 1.2, label=f"{label}: {seeds_phrase(counts[arm])}")
    if "episodes_terminated" in curves and (curves["episodes_terminated"] > 0).any():
        ax.scatter([], [], marker="x", color="grey", label="× an evaluation where an episode fell")
    same = set(counts.values())
    seeds = seeds_phrase(same.pop()) if len(same) == 1 else "each arm's mean over its seeds (see the legend)"
    ax.set(xlabel="environment steps", ylabel="normalized score",
           title=f"{title}\n{seeds}" + ("; thin lines: each seed" if max(counts.values()) > 1 else ""))
    _steps_axis(ax)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    _save(fig, path)


def plot_critic_by_arm(curves: pd.DataFrame, style: dict[str, tuple[str, str]], rewards: dict[str, str], path: Path, title: str) -> None:
    """One panel per arm, in its colour: what its method's reward (``rewards``: arm -> its formula) gives expert
    pairs (solid), the latest policy's (dashed) and random pairs (dotted), mean over seeds, against env steps. A
    policy's reward that stays well below the expert's is a gap the method still sees; one that reaches it while the
    return does not is a reward that no longer tells them apart."""
    plt = _pyplot()
    arms = [arm for arm in style if (curves["arm"] == arm).any()]
    fig, axes = plt.subplots(1, len(arms), figsize=(5 * len(arms), 3.8), squeeze=False)
    for ax, arm in zip(axes[0], arms):
        label, colour = style[arm]
        group = curves[curves["arm"] == arm]
        drawn = []
        for (column, pairs), line in zip(REWARDS.items(), ("-", "--", ":")):
            if column in group and group[column].notna().any():
                means = group.groupby("step")[column].mean()
                ax.plot(means.index, means, color=colour, linestyle=line, label=f"{rewards[arm]} {pairs}")
                drawn.append(means.max())
        bounded = all(top <= 1 for top in drawn)  # σ(−f) is; GAIfO's and PWIL's rewards are not
        ax.set(title=f"{label}: {seeds_phrase(group['seed'].nunique())}", xlabel="environment steps", ylim=(0, 1) if bounded else (0, None))
        _steps_axis(ax)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0, 0].set(ylabel="reward")
    fig.suptitle(title)
    _save(fig, path)


def plot_profile(thresholds, profiles: dict, style: dict[str, tuple[str, str]], path: Path, title: str) -> None:
    """A performance profile per arm (``profiles``: arm -> ((fraction, low, high), tasks, runs)): the fraction of runs
    scoring above each threshold, each task weighing the same, with its bootstrap band where there is one."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for arm, ((fraction, low, high), tasks, runs) in profiles.items():
        label, colour = style[arm]
        ax.step(thresholds, fraction, where="post", color=colour, label=f"{label}: {runs} runs of {tasks} tasks")
        if not pd.isna(low).all():
            ax.fill_between(thresholds, low, high, step="post", color=colour, alpha=0.2)
    ax.set(xlabel="τ: % of our expert's return", ylabel="fraction of runs above τ", ylim=(-0.02, 1.02))
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    _save(fig, path)
