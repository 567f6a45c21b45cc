"""Maintainers: ship demos recorded from an lwail expert with the package.

    python scripts/bundle_expert.py DEMOS_REF [--store DIR]

copies the demos artifact's ``demos.npz`` (state-only, compressed float32) to ``src/lwail_cli/demos/<ENV>.npz``
and writes the env's entry in ``experts.json`` from the demos' and the expert's manifests: mean return,
D4RL-normalized score, training steps, wall time, the evaluation whose actor was kept and why, the command that
continues training, and what a user's run may draw: how many episodes ran to the time limit and the lowest
return against the mean (a one-trajectory run imitates the first episode, so every episode should be an
expert's). The demos must come from ``lwail expert record`` of an ``lwail expert train`` policy.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from lwail_cli import config as cfg
from lwail_cli.artifacts import Store
from lwail_cli.evaluation import d4rl_reference
from lwail_cli.loaders import load_demos, parent

BUNDLE = Path(__file__).resolve().parents[1] / "src" / "lwail_cli" / "demos"


def expert_entry(store: Store, demos_ref: str) -> tuple[str, Path, dict]:
    demos = store.resolve(demos_ref, "demos")
    expert = parent(store, demos, "policy")
    if expert.manifest.get("trained_on") != "true reward":
        raise SystemExit(f"{demos.ref} was not recorded from an `lwail expert train` policy")
    env_id, train = demos.env.id, expert.config["train"]
    episodes, returns = load_demos(demos)
    defaults = json.loads(json.dumps(cfg.to_dict(cfg.TD3Config())))
    overrides = "".join(f" --set td3.{k}={v}" for k, v in expert.config["td3"].items() if defaults[k] != v)
    entry = {
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
    reference = d4rl_reference(env_id)
    if reference is not None:
        entry["d4rl_normalized"] = reference.normalize(entry["mean_return"])
    return env_id, demos.file("demos.npz"), entry


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("demos_ref")
    parser.add_argument("--store", default=None)
    args = parser.parse_args()
    store = Store(args.store)
    problems = [problem for _, problem in store.verify(store.resolve(args.demos_ref, "demos").ref) if problem]
    if problems:
        raise SystemExit("; ".join(problems))
    env_id, npz, entry = expert_entry(store, args.demos_ref)
    shutil.copyfile(npz, BUNDLE / f"{env_id}.npz")
    experts_file = BUNDLE / "experts.json"
    experts = json.loads(experts_file.read_text())
    experts[env_id] = entry
    experts_file.write_text(json.dumps(experts, indent=2) + "\n")
    print(f"bundled {env_id}: {(BUNDLE / f'{env_id}.npz').stat().st_size / 1e3:.0f} kB, {json.dumps(entry)}")


if __name__ == "__main__":
    main()
