"""Side-by-side speed of lwail's imitation loop, a textbook PyTorch TD3, SB3's TD3, and ICVF.

    python -m benchmarks.bench [--steps 4000] [--icvf-steps 3000] [--skip-sb3] [--device cuda]

Prints a table and appends it to benchmarks/results/<date>-<host>.csv. Every loop: Hopper-v5,
256-256 networks, batch 256, one TD3 update per env step, after 1,000 random warm-up steps;
evaluation excluded. lwail's loop includes the LWAIL reward (an ICVF-sized φ, σ(−f) per step,
the critic update and full relabel every 4,000 steps). --device puts every loop's networks and
batches there (the environments stay on the CPU).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from benchmarks.plain_td3 import run_plain_td3
from lwail_cli import config as cfg
from lwail_cli.discriminator import Critic, DiscriminatorTrainer, transition_features
from lwail_cli.envs import describe_env, make_env
from lwail_cli.icvf import Encoder, pretrain_icvf
from lwail_cli.imitation import AdversarialReward
from lwail_cli.replay import ReplayBuffer
from lwail_cli.rollout import rollout
from lwail_cli.td3 import TD3
from lwail_cli.training import train_td3

ENV_ID = "Hopper-v5"
WARMUP = 1_000


def td3_iteration_gflop(obs_dim: int, act_dim: int, hidden: int = 256, batch: int = 256, policy_delay: int = 2) -> float:
    """Matmul FLOPs of one TD3 iteration (backward ≈ 2× forward)."""
    actor = obs_dim * hidden + hidden * hidden + hidden * act_dim
    critic = (obs_dim + act_dim) * hidden + hidden * hidden + hidden
    critic_step = actor + 2 * critic + 3 * (2 * critic)  # target actor, target critics, critics fwd + bwd
    actor_step = 3 * actor + 3 * critic  # actor and critic-1 forward + backward
    return 2 * batch * (critic_step + actor_step / policy_delay) / 1e9


def lwail_loop(steps: int, device: torch.device) -> float:
    info = describe_env(ENV_ID)
    config = cfg.ImitationConfig(td3=cfg.TD3Config(random_steps=WARMUP, learning_starts=WARMUP))
    torch.manual_seed(0)
    encoder = Encoder(info.obs_dim, cfg.ICVFConfig()).to(device).requires_grad_(False)
    expert_episodes = rollout(ENV_ID, None, [1], record=True, transitions=1000).episodes
    with torch.no_grad():
        states = torch.as_tensor(np.concatenate([e.observations[:-1] for e in expert_episodes]), device=device)
        successors = torch.as_tensor(np.concatenate([e.observations[1:] for e in expert_episodes]), device=device)
        expert = transition_features(encoder, states, successors)
    critic = cfg.CriticConfig()
    trainer = DiscriminatorTrainer(Critic(expert.shape[1], critic.hidden).to(device), critic)
    total = WARMUP + steps
    reward = AdversarialReward(encoder, trainer, expert, total + 1, update_every=config.update_every, update_steps=config.update_steps)
    agent = TD3(info, config.td3, device)
    train = cfg.TrainConfig(steps=total + 1, eval_every=10 * total, checkpoint_every=10 * total)
    marks = {}

    def mark(step, run):
        marks[step] = time.perf_counter()

    run_buffer = ReplayBuffer(total + 1, info.obs_dim, info.act_dim, device)
    train_td3(ENV_ID, agent, run_buffer, config.td3, train, 0, reward_model=reward, on_progress=mark, progress_every=math.gcd(WARMUP, steps))
    return steps / (marks[total] - marks[WARMUP])


def sb3_loop(steps: int, device: torch.device) -> float:
    from stable_baselines3 import TD3 as SB3TD3
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.noise import NormalActionNoise

    class Timer(BaseCallback):
        def __init__(self):
            super().__init__()
            self.marks = {}

        def _on_step(self) -> bool:
            if self.num_timesteps in (WARMUP, WARMUP + steps):
                self.marks[self.num_timesteps] = time.perf_counter()
            return True

    env = make_env(ENV_ID)
    act_dim = env.action_space.shape[0]
    model = SB3TD3(
        "MlpPolicy", env, learning_rate=1e-3, buffer_size=WARMUP + steps, learning_starts=WARMUP, batch_size=256,
        train_freq=1, gradient_steps=1, policy_delay=2, action_noise=NormalActionNoise(np.zeros(act_dim), 0.1 * np.ones(act_dim)),
        policy_kwargs={"net_arch": [256, 256]}, device=device, seed=0, verbose=0,
    )
    timer = Timer()
    model.learn(total_timesteps=WARMUP + steps, callback=timer)
    return steps / (timer.marks[WARMUP + steps] - timer.marks[WARMUP])


def icvf_run(steps: int, device: torch.device) -> tuple[float, float, float, float]:
    """(gradient steps/s, seconds to the probe plateau, plateau probe, raw-state probe)."""
    episodes = rollout(ENV_ID, None, [0], record=True, transitions=10_000).episodes
    config = cfg.ICVFConfig(steps=steps, log_every=max(1, steps // 12))
    result = pretrain_icvf(episodes, describe_env(ENV_ID).obs_dim, config, seed=0, device=device)
    log = result.log
    best = log["probe_latent"].max()
    plateau = log[log["probe_latent"] >= best - 0.01].iloc[0]
    return steps / log["wall_time"].iloc[-1], float(plateau["wall_time"]), float(plateau["probe_latent"]), result.probe_raw


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=4_000, help="timed env steps per loop (>= 4000 includes a critic update)")
    parser.add_argument("--icvf-steps", type=int, default=3_000)
    parser.add_argument("--skip-sb3", action="store_true")
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    args = parser.parse_args()
    device = torch.device(args.device)
    info = describe_env(ENV_ID)
    gflop = td3_iteration_gflop(info.obs_dim, info.act_dim)
    rows = [("lwail imitation loop", lwail_loop(args.steps, device))]
    rows.append(("plain PyTorch TD3", run_plain_td3(ENV_ID, WARMUP, args.steps, cfg.TD3Config(), device=device)))
    if not args.skip_sb3:
        rows.append(("Stable-Baselines3 TD3", sb3_loop(args.steps, device)))
    icvf_rate, plateau_s, plateau_probe, raw_probe = icvf_run(args.icvf_steps, device)
    on = torch.cuda.get_device_name(device) if device.type == "cuda" else "CPU"
    machine = f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, {torch.get_num_threads()} threads, on {on}"
    table = [{"measure": f"{name} env-steps/s", "value": rate, "note": f"{1000 / rate:.2f} ms/step, {gflop * rate:.0f} GFLOP/s in TD3 matmuls"} for name, rate in rows]
    lwail_rate = rows[0][1]
    for name, rate in rows[1:]:
        table.append({"measure": f"speed-up vs {name}", "value": lwail_rate / rate, "note": "lwail / baseline"})
    table += [
        {"measure": "ICVF gradient steps/s", "value": icvf_rate, "note": "batch 256, ensemble of 2, 256-wide"},
        {"measure": "ICVF seconds to probe plateau", "value": plateau_s, "note": f"probe {plateau_probe:.3f} (raw states {raw_probe:.3f})"},
    ]
    frame = pd.DataFrame(table)
    frame.insert(0, "date", date.today().isoformat())
    frame["machine"] = machine
    print(f"machine: {machine}; TD3 iteration ≈ {gflop:.3f} GFLOP")
    print(frame[["measure", "value", "note"]].to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    out = Path(__file__).parent / "results" / f"{date.today().isoformat()}-{platform.node()}.csv"
    out.parent.mkdir(exist_ok=True)
    frame.to_csv(out, mode="a", header=not out.exists(), index=False)
    print(f"appended to {out}")


if __name__ == "__main__":
    main()
