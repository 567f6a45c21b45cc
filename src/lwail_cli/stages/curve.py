"""Stage: a run's learning curve and diagnostics drawn and summed up (read by ``loaders.read_curve``, from a finished
policy or from a run still going or killed)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..config import POLICY_NETWORKS
from ..learning_curve import curve_figures, saturated_critic
from ..loaders import live_curve
from ..methods import METHODS
from ..plots import GENERIC_REWARD, plot_run, plot_side_by_side, score_column

if TYPE_CHECKING:
    from pathlib import Path

    import pandas as pd

    from ..artifacts import Store


def plot_curve(curve: pd.DataFrame, path: Path, title: str, reward: str = GENERIC_REWARD) -> Path:
    plot_run(curve, path, None, title, reward)
    return path


def reward_of(store: Store, ref: str) -> str:
    """The reward the run ``ref`` was given, as its figure names it: its method's (methods.base.Method.reward), read
    from its policy artifact; for a run still going or killed, the generic word."""
    if live_curve(store, ref) is not None:
        return GENERIC_REWARD
    method = store.resolve(ref, "policy").config.get("method", "lwail")  # an artifact older than the methods: LWAIL's
    return METHODS[method].reward if method in METHODS else GENERIC_REWARD


def plot_curves(curves: dict[str, pd.DataFrame], path: Path) -> Path:
    plot_side_by_side(curves, path)
    return path


def summary_lines(curve: pd.DataFrame) -> list[str]:
    """One line per evaluated network (the kept one, then the other when logged): its figures over the steps so far."""
    score, steps = score_column(curve), int(curve["step"].max())
    columns = [("kept network", score)] + [
        (f"{name} network (not kept)", f"{name}_{score}") for name in POLICY_NETWORKS if f"{name}_{score}" in curve
    ]
    lines = []
    for label, column in columns:
        figures = curve_figures(curve, steps, column)
        lines.append(
            f"{label}, {column} over {steps} steps: last {figures['at_end']:.1f} · best {figures['best']:.1f} · "
            f"mean of the last 10% {figures['last_10pct_mean']:.1f} · after half the steps: mean "
            f"{figures['second_half_mean']:.1f}, lowest {figures['second_half_min']:.1f} (step {figures['second_half_min_step']:.0f})"
        )
    saturated = saturated_critic(curve)
    return lines + ([saturated] if saturated else [])
