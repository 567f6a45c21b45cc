"""Stage: evaluate a policy on the true reward, optionally as a D4RL-style normalized score."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

from ..config import EvalConfig
from ..envs import describe_env, require_same_env
from ..errors import LwailError
from ..loaders import load_policy, normalized_evaluations, policy_fn
from ..rollout import rollout
from ..video import filmed_rollout
from .shared import expert_return, lineage_demos, now, reference_for_env

if TYPE_CHECKING:
    from pathlib import Path

    from ..artifacts import Store


def evaluate(store: Store, *, policy_ref: str, config: EvalConfig, normalized: bool = False, demos_ref: str | None = None,
             video_dir: Path | None = None) -> dict:
    """Mean ± std true return (and normalized score); with ``video_dir``, an MP4 of each episode there."""
    if demos_ref is not None and not normalized:
        raise LwailError("--demos gives the expert reference of --normalized: add --normalized, or leave --demos out")
    policy = store.resolve(policy_ref, "policy")
    require_same_env(policy.env, describe_env(policy.env.id), f"policy {policy.ref}")
    reference = None
    if normalized:  # found (or refused) before the episodes are played
        demos = store.resolve(demos_ref, "demos") if demos_ref else lineage_demos(store, policy)
        if demos is not None:
            require_same_env(policy.env, demos.env, f"demos {demos.ref}")
        reference = reference_for_env(policy.env.id, demos)
        if reference is None:
            raise LwailError(f"no reference returns for {policy.env.id}: pass --demos with demos that carry returns")
    seeds = range(config.seed, config.seed + config.episodes)
    act = policy_fn(load_policy(policy))
    videos, noise = [], config.env.start_noise
    if video_dir is None:
        played = rollout(policy.env.id, act, seeds, start_noise=noise)
    else:
        played, videos = filmed_rollout(policy.env.id, act, seeds, video_dir, f"{policy.name}-v{policy.version}", start_noise=noise)
    returns = played.returns
    result = {"policy": policy.ref, "episodes": config.episodes, "seed": config.seed, "start_noise": noise,
              "return_mean": float(returns.mean()), "return_std": float(returns.std())}
    if played.success_rate is not None:
        result["success_rate"] = played.success_rate
    if reference is not None:
        result.update(normalized_score=reference.normalize(result["return_mean"]), reference=reference.source)
        expert = expert_return(policy.env.id, demos)
        if expert is not None:
            result["expert_percent"] = 100.0 * result["return_mean"] / expert
    # one fixed set of columns, so every row of evals.csv reads back whether or not it was normalized
    row = {"created": now(), **result, **{key: result.get(key, "") for key in ("normalized_score", "reference", "success_rate", "expert_percent")}}
    try:
        policy.append_log("evals.csv", row)
        not_logged = None
    except OSError as exc:  # e.g. a policy shared read-only: the evaluation itself still counts
        not_logged = f"{exc.strerror or exc} ({exc.filename or policy.path})"
    return result | {"videos": videos, "not_logged": not_logged}


def logged_normalized_evaluation(store: Store, *, policy_ref: str, config: EvalConfig) -> dict | None:
    """The policy's latest normalized evaluation in ``evals.csv`` with these episodes and seed (None if there is none):
    its rollouts are deterministic, so rerunning them only appends the same row again."""
    policy = store.resolve(policy_ref, "policy")
    evals = normalized_evaluations(policy)
    noise = pd.to_numeric(evals["start_noise"], errors="coerce").fillna(0.0) if "start_noise" in evals else 0.0  # older rows: none
    same = evals[(evals["episodes"] == config.episodes) & (evals["seed"] == config.seed) & (noise == config.env.start_noise)]
    return None if same.empty else {"policy": policy.ref, **same.iloc[-1].drop("created").to_dict()}
