"""Stage: a run's learning curve and diagnostics — of a finished policy, or of a run still going or killed."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from ..errors import LwailError
from .plots import plot_run

if TYPE_CHECKING:
    from ..artifacts import Store

CURVE_FILES = ("learning_curve.csv", "training.csv")  # imitate's, expert train's


def read_curve(store: Store, *, ref: str) -> tuple[pd.DataFrame, str]:
    """The curve of the run named ``ref`` while it runs (or after a kill), else of the policy artifact ``ref``;
    with a line saying which was read."""
    for filename in CURVE_FILES:
        try:
            live = store.run_log("policy", ref, filename)
        except LwailError:  # not a plain name (e.g. name@v2 or a path): an artifact ref
            break
        if live.is_file():
            return _read(live), f"run {ref} in progress or killed (last checkpoint kept): {live}"
    policy = store.resolve(ref, "policy")
    for filename in CURVE_FILES:
        if policy.file(filename).is_file():
            return _read(policy.file(filename)), f"{policy.ref}: {policy.file(filename)}"
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
