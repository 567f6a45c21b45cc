"""Stage: a run's learning curve and diagnostics — of a finished policy, or of a run still going or killed."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ..config import POLICY_NETWORKS
from ..errors import LwailError
from ..learning_curve import FILES
from ..plots import plot_run, plot_side_by_side, score_column

if TYPE_CHECKING:
    from ..artifacts import Artifact, Store

LAST_FRACTION = 0.1  # "mean over the last 10% of steps"


def read_curve(store: Store, *, ref: str) -> tuple[pd.DataFrame, str]:
    """The curve of the run named ``ref`` while it runs (or after a kill), else of the policy artifact ``ref``;
    with a line saying which was read."""
    for filename in FILES:
        try:
            live = store.runs.run_log("policy", ref, filename)
        except LwailError:  # not a plain name (e.g. name@v2 or a path): an artifact ref
            break
        if live.is_file():
            return _read(live), f"run {ref} in progress or killed (last checkpoint kept): {live}"
    policy = store.resolve(ref, "policy")
    curve, path = policy_curve(policy)
    return curve, f"{policy.ref}: {path}"


def policy_curve(policy: Artifact) -> tuple[pd.DataFrame, Path]:
    """The learning curve a policy artifact holds, and its file."""
    for filename in FILES:
        if policy.file(filename).is_file():
            return _read(policy.file(filename)), policy.file(filename)
    raise LwailError(f"{policy.ref} holds no learning curve")


def _read(path: Path) -> pd.DataFrame:
    try:
        curve = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise LwailError(f"cannot read the learning curve {path}: {exc}") from None
    if "step" not in curve or "return_mean" not in curve:
        raise LwailError(f"{path} is not a learning curve (no step / return_mean columns)")
    return curve


def plot_curve(curve: pd.DataFrame, path: Path, title: str) -> Path:
    plot_run(curve, path, None, title)
    return path


def plot_curves(curves: dict[str, pd.DataFrame], path: Path) -> Path:
    plot_side_by_side(curves, path)
    return path


def curve_figures(curve: pd.DataFrame, steps: int, final: float | None, column: str = "normalized_score") -> dict[str, float]:
    """A run's figures from its learning curve: the closing evaluation (else the curve's last point), the best
    evaluation, the mean over the last 10% of ``steps``, and the lowest evaluation after half of them (how far the
    network still falls once it has learned: the dips a final score hides)."""
    score, step = curve[column], curve["step"]
    return {
        "final": final if final is not None else float(score.iloc[-1]),
        "best": float(score.max()),
        "last_10pct_mean": float(score[step > (1 - LAST_FRACTION) * steps].mean()),
        "second_half_min": float(_second_half(curve, steps)[column].min()),
    }


def _second_half(curve: pd.DataFrame, steps: int) -> pd.DataFrame:
    return curve[curve["step"] > steps / 2]


def summary_lines(curve: pd.DataFrame) -> list[str]:
    """One line per evaluated network (the kept one, then the other when logged): its figures over the steps so far."""
    score, steps = score_column(curve), int(curve["step"].max())
    columns = [("kept network", score)] + [
        (f"{name} network (not kept)", f"{name}_{score}") for name in POLICY_NETWORKS if f"{name}_{score}" in curve
    ]
    lines = []
    for label, column in columns:
        figures = curve_figures(curve, steps, None, column)
        second_half = _second_half(curve, steps)
        lowest_at = int(second_half.loc[second_half[column].idxmin(), "step"])
        lines.append(
            f"{label}, {column} over {steps} steps: last {figures['final']:.1f} · best {figures['best']:.1f} · "
            f"mean of the last 10% {figures['last_10pct_mean']:.1f} · lowest after half the steps "
            f"{figures['second_half_min']:.1f} (step {lowest_at})"
        )
    return lines
