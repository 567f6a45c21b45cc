"""Statistics over seeds and tasks for `lwail report`: the interquartile mean (IQM), its stratified-bootstrap
confidence interval and the performance profile of Agarwal et al. 2021 ("Deep reinforcement learning at the edge
of the statistical precipice", the estimators of its rliable library), computed with ``scipy.stats.bootstrap``.

A stratified bootstrap resamples the runs of each task (a stratum) on their own, with replacement: what scipy's
bootstrap does with several unpaired samples, one per task. rliable itself is not a dependency: its ``arch``
dependency fails to import under pandas 3. One arm against another: rliable's probability of improvement, and the
difference of means with Welch's interval."""

from __future__ import annotations

import warnings

import numpy as np

from .errors import LwailError

IQM_TRIM = 0.25  # the IQM drops the lowest and highest quarter of the runs (none of 2 or 3: then it is their mean)
CONFIDENCE = 0.95
RESAMPLES = 10_000
BOOTSTRAP_SEED = 0  # fixed: a report rebuilt from the same runs gives the same intervals


def _stats():
    try:
        from scipy import stats
    except ImportError:
        raise LwailError('lwail report needs scipy for its confidence intervals: pip install "lwail[report]"') from None
    return stats


def iqm(scores: np.ndarray, axis: int = -1) -> np.ndarray:
    """The mean of the runs between the 25th and the 75th percentile."""
    return _stats().trim_mean(scores, IQM_TRIM, axis=axis)


def pooled_iqm(by_task: list[np.ndarray]) -> float:
    """The IQM of every run of every task together (the aggregate IQM across tasks)."""
    return float(iqm(np.concatenate(by_task)))


def iqm_interval(by_task: list[np.ndarray]) -> tuple[float, float]:
    """The 95% percentile interval of the pooled IQM under a stratified bootstrap (one stratum per task): (nan, nan)
    where a task has fewer than two runs, which cannot be resampled, or a run has no score."""

    def statistic(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        return iqm(np.concatenate(samples, axis=axis), axis=axis)

    return _interval(by_task, statistic)


def performance_profile(by_task: list[np.ndarray], thresholds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each threshold τ, the fraction of runs scoring above τ (each task weighs the same, whatever its number of
    runs), with the 95% stratified-bootstrap band around it (nan where a task has fewer than two runs)."""

    def statistic(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        runs_last = [np.moveaxis(sample, axis, -1) for sample in samples]
        above = [np.moveaxis(np.mean(sample[..., None] > thresholds, axis=-2), -1, 0) for sample in runs_last]
        return np.mean(above, axis=0)  # (thresholds, ...): scipy's multi-output layout

    profile = statistic(*by_task)
    low, high = _interval(by_task, statistic)
    return profile, np.broadcast_to(low, profile.shape), np.broadcast_to(high, profile.shape)


def _interval(by_task: list[np.ndarray], statistic) -> tuple:
    if min(len(scores) for scores in by_task) < 2 or any(np.isnan(scores).any() for scores in by_task):
        return float("nan"), float("nan")  # nothing to resample, or runs without the figure (no expert return)
    result = _stats().bootstrap(tuple(by_task), statistic, paired=False, vectorized=True, method="percentile",
                                confidence_level=CONFIDENCE, n_resamples=RESAMPLES, rng=np.random.default_rng(BOOTSTRAP_SEED))
    low, high = result.confidence_interval
    return (float(low), float(high)) if np.ndim(low) == 0 else (low, high)


def probability_of_improvement(x: np.ndarray, y: np.ndarray, axis: int = -1) -> np.ndarray:
    """P(X > Y): the share of pairs (a run of X, a run of Y) in which X's scores higher, ties counting half (the
    probability of improvement of Agarwal et al. 2021, on one task)."""
    x_runs, y_runs = np.moveaxis(x, axis, -1)[..., :, None], np.moveaxis(y, axis, -1)[..., None, :]
    return np.mean((x_runs > y_runs) + 0.5 * (x_runs == y_runs), axis=(-2, -1))


def mean_probability_of_improvement(by_task: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float, float]:
    """P(X > Y) averaged over tasks (each weighing the same), with its 95% stratified-bootstrap interval: each task's
    runs of each arm resampled on their own (rliable's aggregate probability of improvement)."""

    def statistic(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        pairs = zip(samples[::2], samples[1::2])
        return np.mean([probability_of_improvement(x, y, axis) for x, y in pairs], axis=0)

    samples = [scores for pair in by_task for scores in pair]
    return (float(statistic(*samples)), *_interval(samples, statistic))


def mean_difference_interval(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The 95% interval of mean(X) − mean(Y) by Welch's t (unequal variances): with 2 or 3 seeds an arm, a percentile
    bootstrap, which resamples only those few values, would be narrower than the evidence allows. (nan, nan) where an
    arm has fewer than two runs or a run has no score."""
    if min(len(x), len(y)) < 2 or np.isnan(x).any() or np.isnan(y).any():
        return float("nan"), float("nan")
    with warnings.catch_warnings():  # runs of equal scores: scipy warns of its moments, the interval is still right
        warnings.simplefilter("ignore", RuntimeWarning)
        interval = _stats().ttest_ind(x, y, equal_var=False).confidence_interval(CONFIDENCE)
    return float(interval.low), float(interval.high)
