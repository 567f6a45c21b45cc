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

# what the method's reward gives three sets of pairs at each evaluation of an imitation run (the learner's metrics;
# LWAIL's σ(−f) also at warm-up): the legend of each is the method's reward (methods.base.Method.reward) then these words
REWARD_EXPERT, PSEUDO_REWARD, REWARD_RANDOM = "reward_expert_mean", "pseudo_reward_mean", "reward_random_mean"
REWARDS = {  # column -> the pairs it is the mean over
    REWARD_EXPERT: "on expert pairs",
    PSEUDO_REWARD: "on the latest policy pairs",
    REWARD_RANDOM: "on random-policy pairs",
}
WASSERSTEIN, PSEUDO_RETURN_SPEARMAN = "wasserstein_estimate", "pseudo_return_spearman"
DISCRIMINATOR_LOSS = "discriminator_loss"  # GAIfO's D instead of f: its cross-entropy at its last update (methods/gaifo.py)
# how much the reward tells the policy apart (issue 40: a saturated f gives a flat reward), at the last update of f:
# the spread of σ(−f) over the latest policy pairs, the mean slope ‖∂σ(−f)/∂s'‖ of that reward in the raw next state
# (through φ: what an action can change), and the mean |Δf| on those pairs over the update (how far f moved)
PSEUDO_REWARD_STD, REWARD_SLOPE, CRITIC_SHIFT = "pseudo_reward_std", "reward_slope_policy", "critic_shift"
# what TD3's critic expects the evaluated policy to earn, min over its twins of Q(s, π(s)), over the states of the
# evaluation's episodes: its mean, and its spread (a flat reward leaves a Q that cannot tell states apart either)
Q_POLICY_MEAN, Q_POLICY_STD = "q_policy_mean", "q_policy_std"
# the inverse-dynamics model's squared error at its last step on the actions it was trained on, and the policy's on
# the actions it infers for the demo (both in [-1, 1] units): BCO's two regressions, OPOLO's model and regulariser
IDM_LOSS, BC_LOSS = "idm_loss", "bc_loss"
SUCCESS_RATE = "success_rate"  # tasks whose env reports info["success"] (the mazes): the episodes that reached the goal

# the columns `lwail curve` prints, in this order, where a curve has them (the rest stay in the file)
TABLE = ("step", "wall_time", "return_mean", "return_std", "normalized_score", SUCCESS_RATE,
         *(f"{name}_normalized_score" for name in POLICY_NETWORKS), *REWARDS, WASSERSTEIN, DISCRIMINATOR_LOSS, PSEUDO_RETURN_SPEARMAN,
         PSEUDO_REWARD_STD, REWARD_SLOPE, CRITIC_SHIFT, Q_POLICY_MEAN, Q_POLICY_STD, IDM_LOSS, BC_LOSS, "episodes_terminated")

LAST_FRACTION = 0.1  # "the last 100k" of a 1M-step run: the evaluations after step 0.9·N
FIGURES = ("at_end", "last_10pct_mean", "second_half_mean", "second_half_min", "best")  # curve_figures' scores


def curve_figures(curve: pd.DataFrame, steps: int, column: str = "normalized_score") -> dict[str, float]:
    """A run's figures from its learning curve, each defined here only: the evaluation at the curve's last step (for
    a finished run of ``steps`` env steps, the row at ``steps``: "at 1M"), the mean of the evaluations after step
    0.9·``steps`` ("the last 100k"), the mean and the lowest of the evaluations after half of them (the mean is what
    decides the default φ, docs/algorithm.md; the lowest is how far the network still falls once it has learned: the
    dips a final score hides), and the best evaluation; with the steps of the lowest and the best."""
    score, step = curve[column], curve["step"]
    later = second_half(curve, steps)[column]
    return {
        "at_end": float(score.iloc[-1]),
        "last_10pct_mean": float(score[step > (1 - LAST_FRACTION) * steps].mean()),
        "second_half_mean": float(later.mean()),
        "second_half_min": float(later.min()),
        "best": float(score.max()),
        "second_half_min_step": _step_of(step, later.idxmin, later),
        "best_step": _step_of(step, score.idxmax, score),
    }


def _step_of(step: pd.Series, where, values: pd.Series) -> float:
    """The step of ``where()`` (idxmin or idxmax of ``values``); nan where no evaluation has a value."""
    return float(step[where()]) if values.notna().any() else float("nan")


def second_half(curve: pd.DataFrame, steps: int) -> pd.DataFrame:
    return curve[curve["step"] > steps / 2]


# An early probe of a run that will not learn (issue 40; docs/algorithm.md, "HalfCheetah's saturated critic"): with the
# tanh loss the Wasserstein estimate is at most 2, and in the 13 paper-table runs the three that never approached the
# expert (HalfCheetah with the authors' φ, Ant without an embedding, both seeds) still had it at ≥ 1.96 at 150k steps,
# every other run ≤ 1.90. Past this level f separates every policy pair from every expert pair by more than tanh's
# range: the reward σ(−f) is near 0 and nearly flat over what the policy reaches.
SATURATION_STEP, SATURATION_LEVEL, TANH_CEILING = 150_000, 1.94, 2.0


def saturated_critic(curve: pd.DataFrame) -> str | None:
    """A warning line if f (tanh loss) is still saturated at the first evaluation from ``SATURATION_STEP`` on, else None."""
    later = curve[curve["step"] >= SATURATION_STEP] if WASSERSTEIN in curve else curve.iloc[:0]
    # a tanh critic's estimate never passes 2: a curve where it does is the plain dual's, which has no such ceiling
    if later.empty or later[WASSERSTEIN].iloc[0] < SATURATION_LEVEL or (curve[WASSERSTEIN] > TANH_CEILING).any():
        return None
    row = later.iloc[0]
    return (f"warning: f is saturated at step {row['step']:.0f} (Wasserstein estimate {row[WASSERSTEIN]:.3f} of tanh's 2; "
            f"σ(−f) {row[REWARD_EXPERT]:.2f} on expert pairs, {row[PSEUDO_REWARD]:.3f} on the policy's): the policy sees a "
            f"nearly flat reward, and every run like this in docs/results stayed far below the expert")
