"""What the metrics an artifact's manifest records (and the diagnostic columns of a learning curve) mean: printed by
``lwail show`` beside them and listed in docs/usage.md. Names with a ``_raw`` suffix are the same probe on raw states
(φ = identity), for comparison; names with a network's prefix (``actor_``, ...) the same figure of that network."""

from __future__ import annotations

from . import learning_curve as curve
from .config import POLICY_NETWORKS
from .methods import METHODS

RAW = "_raw"
# the columns of a learning curve whose name says what they are (or that another entry explains)
SELF_EXPLAINED = ("step", "wall_time", "return_mean", "return_std", "episodes_terminated")
_REWARDS = ", ".join(f"{method.label}'s {method.reward}" for method in METHODS.values())
METRICS: dict[str, str] = {
    # φ's probes (pretrain-icvf; icvf.probe_spearman and icvf.probe_critic_needs)
    "probe_spearman": "time in φ: rank correlation (Spearman) of the distance ‖φ(s_i) − φ(s_j)‖ with the steps |i − j| "
                      "between two states of a held-out random-policy episode (1: φ orders states in time)",
    "probe_separation_auc": "separation AUC: how often a random-policy pair (s, s') lies farther from the first expert "
                            "trajectory than a pair of another expert trajectory does, in the critic's input "
                            "[φ(s), φ(s') − φ(s)] (1: always, 0.5: chance): can f tell expert from random transitions?",
    "probe_progress_spearman": "progress Spearman: rank correlation of the distance from φ(s_t) to φ of the expert's final "
                               "state with the steps left, along the first expert trajectory (1: the distance shrinks at "
                               "every step): does φ show progress along the expert's path?",
    "final_loss": "the ICVF loss, mean over the last icvf.log_every steps",
    # the critic f (warmup-disc; each evaluation of imitate)
    curve.WASSERSTEIN: "the critic's Wasserstein estimate E_policy f − E_expert f (random-policy pairs at warm-up): how far "
                       "apart f finds the two",
    **{column: f"mean reward {pairs}: the run's method's ({_REWARDS}; at warm-up LWAIL's σ(−f))" for column, pairs in curve.REWARDS.items()},
    curve.DISCRIMINATOR_LOSS: "GAIfO's discriminator D at its last update: its binary cross-entropy, expert pairs labelled 1 "
                              "and the latest policy pairs 0 (2·log 2 ≈ 1.39: D cannot tell them apart; near 0: it always can)",
    curve.IDM_LOSS: "BCO's or OPOLO's inverse-dynamics model at its last step: the mean squared error of the actions it infers from "
                    "(s, s') pairs, in [-1, 1] action units (data set I's and the played transitions')",
    curve.BC_LOSS: "the policy's mean squared error against the actions the inverse-dynamics model infers for the demo's "
                   "pairs, in [-1, 1] action units, at its last step (BCO: its cloning loss; OPOLO: its regulariser, before its weight)",
    curve.PSEUDO_RETURN_SPEARMAN: "rank correlation (Spearman) of each evaluation episode's summed reward with its true return "
                                  "(1: the method's reward ranks the episodes as the task does)",
    curve.PSEUDO_REWARD_STD: "the spread (std) of the reward over the latest policy pairs (LWAIL, GAIfO: at the last update; "
                             "PWIL: over the evaluation's episodes): a flat reward (near 0) cannot tell the policy's transitions apart",
    curve.REWARD_SLOPE: "the mean slope ‖∂reward/∂s'‖ of the reward in the raw next state over the latest policy pairs "
                        "(through φ): how much an action can change the reward",
    curve.CRITIC_SHIFT: "the mean |Δf| on the latest policy pairs over the last update of f or D: how far the update moved it",
    curve.Q_POLICY_MEAN: "what TD3's critic expects the evaluated policy to earn, min over its twins of Q(s, π(s)), mean over "
                         "the evaluation's states",
    curve.Q_POLICY_STD: "the spread (std) of that Q(s, π(s)) over the evaluation's states (a flat reward leaves a Q that "
                        "cannot tell states apart either)",
    curve.SUCCESS_RATE: "the fraction of evaluation episodes that reached the goal (tasks whose env reports success: the mazes)",
    # a policy (expert train, imitate)
    "normalized_score": "100·(R − R_random)/(R_expert − R_random) of the last evaluation; the reference is named beside "
                        "it (lwail eval --help)",
}


def meaning(metric: str) -> str | None:
    """What ``metric`` means, or None for one whose name says it (episodes, return_mean, ...)."""
    if metric.endswith(RAW) and metric.removesuffix(RAW) in METRICS:
        return f"{metric.removesuffix(RAW)} on raw states, no φ (to compare with)"
    network = next((name for name in POLICY_NETWORKS if metric.startswith(f"{name}_") and metric.removeprefix(f"{name}_") in METRICS), None)
    if network is not None:
        return f"{metric.removeprefix(f'{network}_')} of the {network} network, evaluated on the same episodes (train.policy)"
    return METRICS.get(metric)
