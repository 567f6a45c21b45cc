"""Stage: a TD3 expert trained on the environment's true reward (and the paper's TD3 baseline)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..config import ExpertConfig
from .shared import PolicyRun, Progress, default_name, reference_for_env, save_weights, train_policy

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store


def train_expert(
    store: Store, *, env_id: str, config: ExpertConfig, seed: int, name: str | None = None, device: torch.device,
    resume: bool = False, on_progress: Progress | None = None,
) -> Artifact:
    def write(writer, result, agent, rewards) -> None:
        # an expert may keep its best evaluation (it trains on the true reward anyway), preferring one without falls
        save_weights(writer.path("actor.safetensors"), result.best_actor)
        save_weights(writer.path("final_actor.safetensors"), agent.network(config.train.policy).state_dict())
        episodes = config.train.eval_episodes
        why = (f"the highest mean return of the evaluations with all {episodes} episodes complete" if result.best_complete
               else f"no evaluation had all {episodes} episodes complete: the highest mean return")
        writer.metrics.update({
            "actor": f"best evaluation, at step {result.best_step}", "kept_because": why,
            "best_return_mean": result.best_return, "best_complete": result.best_complete,
        })

    run = PolicyRun(
        env_id=env_id, name=name or default_name(env_id, "expert"), config=config, seed=seed, parents=[],
        trained_on="true reward", reference=reference_for_env(env_id), reward_model=None, write=write,
    )
    return train_policy(store, run, device=device, resume=resume, on_progress=on_progress)
