"""Pictures of a run's learning curve and diagnostics (used by `imitate` and `curve`; not a stage)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

REWARD_COLUMNS = {  # column -> legend
    "reward_expert_mean": "σ(−f) on expert pairs",
    "pseudo_reward_mean": "σ(−f) on the latest policy pairs",
    "reward_random_mean": "σ(−f) on random-policy pairs",
}


def score_column(history: pd.DataFrame) -> str:
    if "normalized_score" in history and history["normalized_score"].notna().any():
        return "normalized_score"
    return "return_mean"


def plot_run(history: pd.DataFrame, curve_path: Path, scatter_path: Path | None, title: str) -> None:
    """The score against env steps above the critic's rewards; and, when asked, pseudo-reward vs true return."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    score = score_column(history)
    rewards = [column for column in REWARD_COLUMNS if column in history]
    fig, axes = plt.subplots(2 if rewards else 1, 1, figsize=(7, 6 if rewards else 4), sharex=True, squeeze=False)
    top = axes[0, 0]
    top.plot(history["step"], history[score], marker="o", markersize=3)
    top.set(ylabel=score.replace("_", " "), title=title)
    top.grid(alpha=0.3)
    if rewards:
        bottom = axes[1, 0]
        for column in rewards:
            bottom.plot(history["step"], history[column], label=REWARD_COLUMNS[column])
        bottom.set(ylabel="reward", ylim=(0, 1))
        bottom.legend(fontsize=8)
        bottom.grid(alpha=0.3)
    axes[-1, 0].set(xlabel="environment steps")
    fig.tight_layout()
    fig.savefig(curve_path, dpi=100)
    plt.close(fig)
    if scatter_path is None or "pseudo_reward_mean" not in history:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    points = ax.scatter(history["pseudo_reward_mean"], history["return_mean"], c=history["step"], cmap="viridis")
    fig.colorbar(points, label="environment steps")
    ax.set(xlabel="mean pseudo-reward σ(−f) of recent transitions", ylabel="true return", title="pseudo-reward vs true return")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(scatter_path, dpi=100)
    plt.close(fig)
