"""The learning curve of an online TD3 run (`expert train`, `imitate`): one CSV row per evaluation.

Its file name and its columns, for the code that writes it (the run skeleton, imitation's diagnostics) and the
code that reads it (`lwail curve`, the sweep report, the plots)."""

from __future__ import annotations

import pandas as pd

from .config import POLICY_NETWORKS

FILE = "learning_curve.csv"
# the names to look for, newest first: up to 9b43183 `expert train` wrote training.csv, read only as a fallback
# so that its policy artifacts and its runs in flight (killed, or resumed by this code) still show their curves
FILES = (FILE, "training.csv")

# what the critic f says at each evaluation of an LWAIL run (imitation.AdversarialReward.metrics)
REWARD_EXPERT, PSEUDO_REWARD, REWARD_RANDOM = "reward_expert_mean", "pseudo_reward_mean", "reward_random_mean"
REWARDS = {  # column -> legend
    REWARD_EXPERT: "σ(−f) on expert pairs",
    PSEUDO_REWARD: "σ(−f) on the latest policy pairs",
    REWARD_RANDOM: "σ(−f) on random-policy pairs",
}
WASSERSTEIN, PSEUDO_RETURN_SPEARMAN = "wasserstein_estimate", "pseudo_return_spearman"
# how much the reward tells the policy apart (issue 40: a saturated f gives a flat reward), at the last update of f:
# the spread of σ(−f) over the latest policy pairs, the mean slope ‖∂σ(−f)/∂s'‖ of that reward in the raw next state
# (through φ: what an action can change), and the mean |Δf| on those pairs over the update (how far f moved)
PSEUDO_REWARD_STD, REWARD_SLOPE, CRITIC_SHIFT = "pseudo_reward_std", "reward_slope_policy", "critic_shift"

# the columns `lwail curve` prints, in this order, where a curve has them (the rest stay in the file)
TABLE = ("step", "wall_time", "return_mean", "return_std", "normalized_score",
         *(f"{name}_normalized_score" for name in POLICY_NETWORKS), *REWARDS, WASSERSTEIN, PSEUDO_RETURN_SPEARMAN,
         PSEUDO_REWARD_STD, REWARD_SLOPE, CRITIC_SHIFT, "episodes_terminated")

LAST_FRACTION = 0.1  # "mean over the last 10% of steps"
FIGURES = ("final", "best", "last_10pct_mean", "second_half_mean", "second_half_min")  # curve_figures' keys


def curve_figures(curve: pd.DataFrame, steps: int, final: float | None, column: str = "normalized_score") -> dict[str, float]:
    """A run's figures from its learning curve: the closing evaluation (else the curve's last point), the best
    evaluation, the mean over the last 10% of ``steps``, and the mean and the lowest of the evaluations after half
    of them (the mean is what decides the default φ, docs/algorithm.md; the lowest is how far the network still
    falls once it has learned: the dips a final score hides)."""
    score, step = curve[column], curve["step"]
    later = second_half(curve, steps)[column]
    return {
        "final": final if final is not None else float(score.iloc[-1]),
        "best": float(score.max()),
        "last_10pct_mean": float(score[step > (1 - LAST_FRACTION) * steps].mean()),
        "second_half_mean": float(later.mean()),
        "second_half_min": float(later.min()),
    }


def second_half(curve: pd.DataFrame, steps: int) -> pd.DataFrame:
    return curve[curve["step"] > steps / 2]
