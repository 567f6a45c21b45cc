"""Stage: a TD3 expert trained on the environment's true reward (and the paper's TD3 baseline)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import config as cfg
from .. import learning_curve
from ..envs import describe_env
from ..loaders import save_weights
from ..runs import open_run, run_record
from .online import final_metrics, session, start_online_run, train_policy, write_curve
from .shared import Progress, default_name, reference_for_env

if TYPE_CHECKING:
    import torch

    from ..artifacts import Artifact, Store


def train_expert(
    store: Store, *, env_id: str, config: cfg.ExpertConfig, seed: int, name: str | None = None, device: torch.device,
    resume: bool = False, on_progress: Progress | None = None,
) -> Artifact:
    name = name or default_name(env_id, "expert")
    reference = reference_for_env(env_id)
    info = describe_env(env_id)
    record = cfg.to_dict(config)
    with open_run(store, "policy", name, resume=resume, record=run_record(record, seed, env_id, []), config_class=cfg.ExpertConfig) as run:
        capacity = start_online_run(run, info, config, seed)
        hooks = session(run, info=info, seed=seed, device=device, reference=reference, on_progress=on_progress)
        trained = train_policy(hooks, config=config, capacity=capacity)
        state = trained.state
        with store.create("policy", name, env=info, config=record, seed=seed, parents=[], extra={"trained_on": "true reward"}) as writer:
            write_curve(writer.path(learning_curve.FILE), state)
            # an expert may keep its best evaluation (it trains on the true reward anyway), preferring one without falls
            save_weights(writer.path("actor.safetensors"), state.best_actor)
            save_weights(writer.path("final_actor.safetensors"), trained.agent.network(config.train.policy).state_dict())
            episodes = config.train.eval_episodes
            why = (f"the highest mean return of the evaluations with all {episodes} episodes complete" if state.best_complete
                   else f"no evaluation had all {episodes} episodes complete: the highest mean return")
            writer.metrics.update({
                "actor": f"best evaluation, at step {state.best_step}", "kept_because": why,
                "best_return_mean": state.best_return, "best_complete": state.best_complete,
            })
            writer.metrics.update(final_metrics(state, reference))
    return writer.artifact
