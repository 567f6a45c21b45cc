"""What the metrics an artifact's manifest records mean: printed by ``lwail show`` beside them and listed in
docs/usage.md. Names with a ``_raw`` suffix are the same probe on raw states (φ = identity), for comparison."""

from __future__ import annotations

from .learning_curve import REWARDS, WASSERSTEIN

RAW = "_raw"
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
    WASSERSTEIN: "the critic's Wasserstein estimate E_policy f − E_expert f (random-policy pairs at warm-up): how far "
                 "apart f finds the two",
    **{column: f"mean reward {legend}" for column, legend in REWARDS.items()},
    # a policy (expert train, imitate)
    "normalized_score": "100·(R − R_random)/(R_expert − R_random) of the last evaluation; the reference is named beside "
                        "it (lwail eval --help)",
}


def meaning(metric: str) -> str | None:
    """What ``metric`` means, or None for one whose name says it (episodes, return_mean, ...)."""
    if metric.endswith(RAW) and metric.removesuffix(RAW) in METRICS:
        return f"{metric.removesuffix(RAW)} on raw states, no φ (to compare with)"
    return METRICS.get(metric)
