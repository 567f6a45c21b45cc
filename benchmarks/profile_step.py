"""Where one LWAIL imitation step's time goes, on one thread: a table of exclusive CPU time per part.

    OMP_NUM_THREADS=1 python -m benchmarks.profile_step --env Hopper-v5 [--steps 20000] [--warmup 10000] [--eval-every 10000]

Runs ``train_td3`` on the LWAIL reward as ``lwail imitate`` does (``benchmarks/lwail_setup.py``: the stage's parts at
the stage's sizes, ``train.average_tau=0.001`` as the plans set it, so three networks are evaluated) and times each
part by wrapping it: a part's time excludes the parts inside it (the actor forwards inside an evaluation are the
evaluation's, not the update's). Steps before ``--warmup`` take random actions and make no update; only the steps
after it are counted. Evaluations are reported per evaluation and projected to a 1M-step run at full-length
episodes (10 episodes x 1,000 steps x 3 networks every 10,000 steps), since early policies fall in a few steps.
Times are the process's CPU time, not wall time: on a machine shared with other runs, wall time mostly measures
the scheduler.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import torch

from benchmarks.lwail_setup import build_lwail
from lwail_cli import config as cfg
from lwail_cli import td3 as td3_module
from lwail_cli import training
from lwail_cli.envs import CheckedEnv

FULL_EVALUATION_ENV_STEPS = 3 * 10 * 1000  # three networks, ten episodes, at most 1,000 steps each
RUN_EVAL_EVERY = cfg.TrainConfig().eval_every  # a real run's schedule, whatever --eval-every the profile used


class PartTimer:
    """Exclusive CPU time per label: a wrapped call's time minus the wrapped calls inside it."""

    def __init__(self):
        self.seconds = defaultdict(float)
        self.calls = defaultdict(int)
        self._stack: list[list] = []  # [label, time spent in children]
        self.counting = False

    def wrap(self, fn, label):
        def timed(*args, **kwargs):
            if not self.counting:
                return fn(*args, **kwargs)
            name = label(self._stack) if callable(label) else label
            if name is None:  # counted as its caller's
                return fn(*args, **kwargs)
            frame = [name, 0.0]
            self._stack.append(frame)
            start = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = time.process_time() - start
                self._stack.pop()
                self.seconds[name] += spent - frame[1]
                self.calls[name] += 1
                if self._stack:
                    self._stack[-1][1] += spent

        return timed

    def patch(self, owner, attribute, label):
        setattr(owner, attribute, self.wrap(getattr(owner, attribute), label))


def inside(prefix: str, name: str):
    """Label ``name`` when called inside a part whose label starts with ``prefix``; else leave it to the caller."""
    return lambda stack: name if stack and stack[-1][0].startswith(prefix) else None


def instrument(timer: PartTimer, parts) -> None:
    agent, buffer, reward = parts.agent, parts.buffer, parts.reward
    backward_calls = [0]

    def update_label(stack):
        backward_calls[0] = 0
        return "TD3 update: other tensor ops (noise, targets, losses, cat, zero_grad)"

    timer.patch(agent, "update", update_label)
    for module, name in ((agent.critic, "critic"), (agent.critic_target, "critic target"), (agent.actor, "actor"), (agent.actor_target, "actor target")):
        timer.patch(module, "forward", inside("TD3 update", f"TD3 update: {name} forward"))
    timer.patch(agent.critic_optimizer, "step", "TD3 update: critic Adam step")
    timer.patch(agent.actor_optimizer, "step", "TD3 update: actor Adam step")
    timer.patch(td3_module, "soft_update", "TD3 update: Polyak target/average updates")
    backward = torch.autograd.backward

    def backward_label(stack):
        if not stack or not stack[-1][0].startswith("TD3 update"):
            return None
        backward_calls[0] += 1
        return "TD3 update: critic backward" if backward_calls[0] == 1 else "TD3 update: actor backward"

    torch.autograd.backward = timer.wrap(backward, backward_label)
    timer.patch(buffer, "sample", "replay: sample a batch")
    timer.patch(buffer, "add", "replay: add a transition")
    timer.patch(agent, "act", lambda stack: "action selection (agent.act, one obs)" if not stack else None)
    timer.patch(reward, "prepare", "reward: per-step σ(−f) of the new transition (φ, f)")
    timer.patch(reward.trainer, "train", "reward: train f (every update_every)")
    timer.patch(reward, "relabel", "reward: relabel the buffer (every update_every)")
    timer.patch(reward, "_cache_features", "reward: cache φ features (every update_every)")
    timer.patch(training, "evaluate_policy", "evaluation: reward diagnostics, scores, keeping the best")
    def env_label(stack):  # the environments of training and of evaluations are the same class
        return "evaluation: environment steps" if stack and stack[-1][0].startswith("evaluation") else "environment step (training)"

    timer.patch(CheckedEnv, "step", env_label)
    timer.patch(CheckedEnv, "reset", lambda stack: None if stack else "environment step (training)")
    timer.patch(training, "rollout", "evaluation: rollout loop and batched actor forwards")
    original_evaluate = training.evaluate_policy

    def counted_evaluate(*args, **kwargs):
        timer.evaluations += 1
        return original_evaluate(*args, **kwargs)

    timer.evaluations = 0
    training.evaluate_policy = counted_evaluate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="Hopper-v5")
    parser.add_argument("--steps", type=int, default=20_000, help="counted imitation steps after the warm-up")
    parser.add_argument("--warmup", type=int, default=10_000, help="random-action steps before them (td3.random_steps)")
    parser.add_argument("--eval-every", type=int, default=10_000)
    args = parser.parse_args()
    torch.set_num_threads(1)
    parts = build_lwail(args.env, warmup=args.warmup, steps=args.steps, device=torch.device("cpu"), eval_every=args.eval_every, average_tau=0.001)
    timer = PartTimer()
    instrument(timer, parts)
    start = {}

    def on_progress(step, run):
        if step == args.warmup:
            timer.counting = True
            start["t"] = time.process_time()

    training.train_td3(args.env, parts.agent, parts.buffer, parts.config.td3, parts.config.train, 0, reward_model=parts.reward,
                       on_progress=on_progress, progress_every=args.warmup)
    total = time.process_time() - start["t"]
    evaluation_steps = timer.calls["evaluation: environment steps"]
    evaluation_seconds = sum(v for k, v in timer.seconds.items() if k.startswith("evaluation"))
    loop_seconds = total - evaluation_seconds
    rows = dict(timer.seconds)
    rows["loop: the rest (noise, clip, bookkeeping, timer wrappers)"] = total - sum(timer.seconds.values())
    print(f"{args.env}: {args.steps} imitation steps after {args.warmup} warm-up steps, {timer.evaluations} evaluations "
          f"({evaluation_steps} evaluation env steps), {total:.1f} s of CPU, torch {torch.__version__}, {torch.get_num_threads()} thread")
    print()
    print("| part | µs per imitation step | share of the loop without evaluations |")
    print("|---|---:|---:|")
    for name, seconds in sorted(rows.items(), key=lambda item: -item[1]):
        if not name.startswith("evaluation"):
            print(f"| {name} | {1e6 * seconds / args.steps:.0f} | {100 * seconds / loop_seconds:.1f}% |")
    print(f"| **loop without evaluations** | **{1e6 * loop_seconds / args.steps:.0f}** | 100% |")
    print()
    print("| evaluation part | µs per evaluation env step | ms per evaluation | share of evaluation time |")
    print("|---|---:|---:|---:|")
    for name, seconds in sorted(rows.items(), key=lambda item: -item[1]):
        if name.startswith("evaluation"):
            print(f"| {name} | {1e6 * seconds / evaluation_steps:.1f} | {1e3 * seconds / timer.evaluations:.0f} | {100 * seconds / evaluation_seconds:.1f}% |")
    per_eval_step = evaluation_seconds / evaluation_steps
    projected = loop_seconds / args.steps + per_eval_step * FULL_EVALUATION_ENV_STEPS / RUN_EVAL_EVERY
    print()
    print(f"loop without evaluations: {args.steps / loop_seconds:.1f} steps/s; evaluation: {1e6 * per_eval_step:.0f} µs per env step; "
          f"1M steps with full-length evaluations every {RUN_EVAL_EVERY}: {projected * 1e6 / 3600:.2f} h of CPU ({1 / projected:.1f} steps/s)")


if __name__ == "__main__":
    main()
