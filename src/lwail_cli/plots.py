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


def plot_run(history: pd.DataFrame, curve_path: Path, scatter_path: Path | None, title: str) -> None:
    """The score against env steps above the critic's rewards; and, when asked, pseudo-reward vs true return."""
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
            bottom.plot(history["step"], history[column], label=REWARDS[column])
        bottom.set(ylabel="reward", ylim=(0, 1))
        bottom.legend(fontsize=8)
        bottom.grid(alpha=0.3)
    axes[-1, 0].set(xlabel="environment steps")
    _save(fig, curve_path)
    if scatter_path is None or PSEUDO_REWARD not in history:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    points = ax.scatter(history[PSEUDO_REWARD], history["return_mean"], c=history["step"], cmap="viridis")
    fig.colorbar(points, label="environment steps")
    ax.set(xlabel="mean pseudo-reward σ(−f) of recent transitions", ylabel="true return", title="pseudo-reward vs true return")
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


def plot_critic_by_kind(curves: pd.DataFrame, path: Path, title: str) -> None:
    """One panel per embedding kind: what the critic says (σ(−f) on expert, latest policy and random pairs, mean over
    seeds) against env steps. A policy's reward that stays well below the expert's is a gap f still sees; one that
    reaches it while the return does not is a critic that no longer tells them apart."""
    plt = _pyplot()
    kinds = sorted(curves["kind"].unique())
    fig, axes = plt.subplots(1, len(kinds), figsize=(5 * len(kinds), 3.8), sharey=True, squeeze=False)
    for ax, kind in zip(axes[0], kinds):
        group = curves[curves["kind"] == kind]
        for column, legend in REWARDS.items():
            if column in group and group[column].notna().any():
                means = group.groupby("step")[column].mean()
                ax.plot(means.index, means, label=legend)
        ax.set(title=f"{kind} (n={group['seed'].nunique()})", xlabel="environment steps", ylim=(0, 1))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0, 0].set(ylabel="reward σ(−f)")
    fig.suptitle(title)
    _save(fig, path)


def plot_bands(curves: pd.DataFrame, path: Path, title: str) -> None:
    """Mean ± std over seeds of the normalized score against env steps, one band per embedding kind."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for kind, group in curves.groupby("kind"):
        stats = group.groupby("step")["normalized_score"].agg(["mean", "std", "count"]).fillna({"std": 0.0})
        ax.plot(stats.index, stats["mean"], label=f"{kind} (n={int(stats['count'].max())})")
        ax.fill_between(stats.index, stats["mean"] - stats["std"], stats["mean"] + stats["std"], alpha=0.25)
    ax.set(xlabel="environment steps", ylabel="normalized score", title=title)
    ax.legend()
    ax.grid(alpha=0.3)
    _save(fig, path)
