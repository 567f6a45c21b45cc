"""Maintainers: ship demos recorded from an lwail expert with the package.

    python scripts/bundle_expert.py DEMOS_REF [--store DIR]
    python scripts/bundle_expert.py --cut BUNDLED_ENV --for ENV

copies the demos artifact's ``demos.npz`` (state-only, compressed float32) to ``src/lwail_cli/demos/<ENV>.npz``
and writes the env's entry in ``experts.json`` from the demos' and the expert's manifests: mean return,
D4RL-normalized score, training steps, wall time, the evaluation whose actor was kept and why, the command that
continues training, and what a user's run may draw: how many episodes ran to the time limit and the lowest
return against the mean (a one-trajectory run imitates the first episode, so every episode should be an
expert's). The demos must come from ``lwail expert record`` of an ``lwail expert train`` policy, or from the maze
planner (``lwail demos import PointMaze... --planner``: its entry says so, with its success rate).

``--cut`` ships a bundled env's episodes for an env that observes a prefix of what it observes (the same task,
e.g. AntNoContactForces-v5 of Ant-v5): each observation keeps its first entries, after a random rollout of both
envs has shown the prefix is the whole of the other's observation and the rewards are the same.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np

from lwail_cli import config as cfg
from lwail_cli.artifacts import Store
from lwail_cli.envs import make_env
from lwail_cli.evaluation import d4rl_reference
from lwail_cli.formats.npz import read_npz, write_npz
from lwail_cli.loaders import load_demos, parent

BUNDLE = Path(__file__).resolve().parents[1] / "src" / "lwail_cli" / "demos"


def planner_entry(demos) -> dict:
    """What experts.json says of the maze planner's demos: no training, its episodes' returns and success rate."""
    noise = demos.config["env"]["start_noise"]
    return {
        "mean_return": demos.metrics["mean_return"], "return_std": demos.metrics["return_std"], "episodes": demos.metrics["episodes"],
        "obs_dim": demos.env.obs_dim, "success_rate": demos.metrics["success_rate"],
        "expert": (f"the maze planner (shortest path over the cells, PD control along it, as D4RL's maze2d), seed {demos.manifest['seed']} "
                   f"(lwail demos import {demos.env.id} --planner --episodes {demos.metrics['episodes']} --seed {demos.manifest['seed']}"
                   + (f" --start-noise {noise}" if noise else "") + ")"),
    }


def expert_entry(store: Store, demos_ref: str) -> tuple[str, Path, dict]:
    demos = store.resolve(demos_ref, "demos")
    entry = planner_entry(demos) if demos.config.get("source") == "planner" else trained_entry(store, demos)
    reference = d4rl_reference(demos.env.id)
    if reference is not None:
        entry["d4rl_normalized"] = reference.normalize(entry["mean_return"])
    return demos.env.id, demos.file("demos.npz"), entry


def trained_entry(store: Store, demos) -> dict:
    """What experts.json says of demos recorded from an `lwail expert train` policy."""
    expert = parent(store, demos, "policy")
    if expert.manifest.get("trained_on") != "true reward":
        raise SystemExit(f"{demos.ref} was not recorded from an `lwail expert train` policy")
    env_id, train = demos.env.id, expert.config["train"]
    episodes, returns = load_demos(demos)
    defaults = json.loads(json.dumps(cfg.to_dict(cfg.TD3Config())))
    overrides = "".join(f" --set td3.{k}={v}" for k, v in expert.config["td3"].items() if defaults[k] != v)
    return {
        "mean_return": demos.metrics["mean_return"],
        "return_std": demos.metrics["return_std"],
        "episodes": demos.metrics["episodes"],
        "obs_dim": demos.env.obs_dim,
        "complete_episodes": sum(not episode.terminated for episode in episodes),  # none ended by a fall
        "lowest_return": float(returns.min()),
        "lowest_to_mean": float(returns.min() / returns.mean()),
        "training_steps": expert.metrics["env_steps"],
        "wall_time_s": expert.metrics["wall_time_s"],
        "expert": (
            f"TD3 on the true reward, {expert.metrics['env_steps']} env steps, evaluated every {train['eval_every']} "
            f"({expert.metrics['actor']}: {expert.metrics.get('kept_because', 'the highest mean return')}), seed {expert.manifest['seed']} "
            f"(lwail expert train {env_id} --steps {train['steps']} --eval-every {train['eval_every']}{overrides})"
        ),
    }


def observed_prefix(source_env: str, target_env: str, steps: int = 300, seed: int = 0) -> int:
    """How many leading entries of ``source_env``'s observation ``target_env`` observes, checked on a random rollout
    of both (same seed, same actions): the rest of each observation, the rewards and the ends must agree."""
    source, target = make_env(source_env), make_env(target_env)
    kept = target.observation_space.shape[0]
    not_a_prefix = f"{target_env} does not observe the first {kept} entries of {source_env}'s observation"
    actions = np.random.default_rng(seed).uniform(source.action_space.low, source.action_space.high, (steps, *source.action_space.shape))
    try:
        full, cut = source.reset(seed=seed)[0], target.reset(seed=seed)[0]
        for action in actions:
            if not np.array_equal(full[:kept], cut):
                raise SystemExit(not_a_prefix)
            (full, reward, *ends, _), (cut, cut_reward, *cut_ends, _) = source.step(action), target.step(action)
            if (reward, *ends) != (cut_reward, *cut_ends):
                raise SystemExit(f"{target_env} and {source_env} differ in reward or episode ends: not the same task")
            if any(ends):
                break
        if not np.array_equal(full[:kept], cut):
            raise SystemExit(not_a_prefix)
    finally:
        source.close()
        target.close()
    return kept


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("demos_ref", nargs="?")
    parser.add_argument("--store", default=None)
    parser.add_argument("--cut", metavar="BUNDLED_ENV", help="ship this bundled env's episodes for --for ENV")
    parser.add_argument("--for", dest="target_env", metavar="ENV")
    args = parser.parse_args()
    experts_file = BUNDLE / "experts.json"
    experts = json.loads(experts_file.read_text())
    if args.cut:
        if args.demos_ref or not args.target_env:
            raise SystemExit("--cut BUNDLED_ENV needs --for ENV and no DEMOS_REF")
        env_id, kept = args.target_env, observed_prefix(args.cut, args.target_env)
        episodes, returns = read_npz(BUNDLE / f"{args.cut}.npz")
        episodes = [dataclasses.replace(episode, observations=episode.observations[:, :kept]) for episode in episodes]
        write_npz(BUNDLE / f"{env_id}.npz", episodes, returns)
        entry = {**experts[args.cut], "obs_dim": kept}
        entry["expert"] = f"the {args.cut} bundle's episodes, each observation cut to its first {kept} entries (all {env_id} observes): {entry['expert']}"
    else:
        store = Store(args.store)
        problems = [problem for _, problem in store.verify(store.resolve(args.demos_ref, "demos").ref) if problem]
        if problems:
            raise SystemExit("; ".join(problems))
        env_id, npz, entry = expert_entry(store, args.demos_ref)
        shutil.copyfile(npz, BUNDLE / f"{env_id}.npz")
    experts[env_id] = entry
    experts_file.write_text(json.dumps(experts, indent=2) + "\n")
    print(f"bundled {env_id}: {(BUNDLE / f'{env_id}.npz').stat().st_size / 1e3:.0f} kB, {json.dumps(entry)}")


if __name__ == "__main__":
    main()
