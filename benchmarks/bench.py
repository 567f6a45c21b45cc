"""Side-by-side speed of lwail's TD3 update and imitation step, a textbook PyTorch TD3, SB3's TD3, and ICVF.

    OMP_NUM_THREADS=1 python -m benchmarks.bench [--steps 4000] [--updates 2000] [--icvf-steps 3000] [--skip-sb3] [--device cuda]

Prints a table and appends it to benchmarks/results/<date>-<host>.csv. Everything: Hopper-v5, 256-256 networks,
batch 256, after 1,000 random warm-up steps; evaluation excluded. Two kinds of rows, each in CPU time (what a run
costs on a shared machine, where wall time mostly measures the scheduler) and wall time:

- TD3 update: the update alone (sample a batch, critic and, every other call, actor and target updates), from the
  same 1,000 random transitions; SB3's is ``model.train(gradient_steps=1)``, its own sampling and logging included.
- full step: one env step, action selection, one update and the bookkeeping: lwail's imitation step (the LWAIL
  reward: φ and σ(−f) per step, f's update and the relabel every 4,000 steps), lwail's loop on the true reward
  (the same work as the textbook and SB3 loops), the textbook loop, and SB3's ``learn``.

--device puts every loop's networks and batches there (the environments stay on the CPU).
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

from benchmarks.lwail_setup import build_lwail
from benchmarks.plain_td3 import PlainReplayBuffer, PlainTD3, run_plain_td3
from lwail_cli import config as cfg
from lwail_cli.envs import describe_env, make_env
from lwail_cli.icvf import pretrain_icvf
from lwail_cli.replay import ReplayBuffer
from lwail_cli.rollout import rollout
from lwail_cli.td3 import TD3
from lwail_cli.training import EnvironmentReward, train_td3

ENV_ID = "Hopper-v5"
WARMUP = 1_000


def td3_iteration_gflop(obs_dim: int, act_dim: int, hidden: int = 256, batch: int = 256, policy_delay: int = 2) -> float:
    """Matmul FLOPs of one TD3 iteration (backward ≈ 2× forward)."""
    actor = obs_dim * hidden + hidden * hidden + hidden * act_dim
    critic = (obs_dim + act_dim) * hidden + hidden * hidden + hidden
    critic_step = actor + 2 * critic + 3 * (2 * critic)  # target actor, target critics, critics fwd + bwd
    actor_step = 3 * actor + 3 * critic  # actor and critic-1 forward + backward
    return 2 * batch * (critic_step + actor_step / policy_delay) / 1e9


def timed(calls: int, call) -> tuple[float, float]:
    """(CPU seconds, wall seconds) per call of ``call()``, after a few untimed ones."""
    for _ in range(10):
        call()
    cpu, wall = time.process_time(), time.perf_counter()
    for _ in range(calls):
        call()
    return (time.process_time() - cpu) / calls, (time.perf_counter() - wall) / calls


def random_transitions(env_id: str) -> list[tuple]:
    """WARMUP (obs, action, reward, next_obs, terminated) of a random policy, for every update benchmark."""
    env = make_env(env_id, seed=0)
    obs, _ = env.reset(seed=0)
    rows = []
    for _ in range(WARMUP):
        action = env.action_space.sample()
        next_obs, reward, terminated, truncated, _ = env.step(action)
        rows.append((obs, action, float(reward), next_obs, bool(terminated)))
        obs = env.reset()[0] if terminated or truncated else next_obs
    env.close()
    return rows


def lwail_update(updates: int, transitions: list[tuple], device: torch.device) -> tuple[float, float]:
    info = describe_env(ENV_ID)
    torch.manual_seed(0)
    agent = TD3(info, cfg.TD3Config(), device)
    buffer = ReplayBuffer(WARMUP, info.obs_dim, info.act_dim, device)
    for row in transitions:
        buffer.add(*row)
    return timed(updates, lambda: agent.update(buffer.sample(256)))


def plain_update(updates: int, transitions: list[tuple], device: torch.device) -> tuple[float, float]:
    info = describe_env(ENV_ID)
    torch.manual_seed(0)
    agent = PlainTD3(info, cfg.TD3Config(), device)
    buffer = PlainReplayBuffer(WARMUP, info.obs_dim, info.act_dim, device)
    for obs, action, reward, next_obs, terminated in transitions:
        buffer.add(obs, action, reward, next_obs, float(terminated))
    return timed(updates, lambda: agent.update(buffer.sample(256)))


def sb3_model(steps: int, device: torch.device):
    from stable_baselines3 import TD3 as SB3TD3
    from stable_baselines3.common.noise import NormalActionNoise

    env = make_env(ENV_ID)
    act_dim = env.action_space.shape[0]
    return SB3TD3(
        "MlpPolicy", env, learning_rate=1e-3, buffer_size=WARMUP + steps, learning_starts=WARMUP, batch_size=256,
        train_freq=1, gradient_steps=1, policy_delay=2, action_noise=NormalActionNoise(np.zeros(act_dim), 0.1 * np.ones(act_dim)),
        policy_kwargs={"net_arch": [256, 256]}, device=device, seed=0, verbose=0,
    )


def sb3_update(updates: int, device: torch.device) -> tuple[float, float]:
    model = sb3_model(updates, device)
    model.learn(total_timesteps=WARMUP)  # random warm-up transitions only (learning_starts = WARMUP)
    return timed(updates, lambda: model.train(gradient_steps=1, batch_size=256))


def lwail_loop(steps: int, device: torch.device, imitation: bool) -> tuple[float, float]:
    parts = build_lwail(ENV_ID, warmup=WARMUP, steps=steps + 1, device=device)
    marks = {}

    def mark(step, run):
        marks[step] = time.process_time(), time.perf_counter()

    reward = parts.reward if imitation else EnvironmentReward()
    train_td3(ENV_ID, parts.agent, parts.buffer, parts.config.td3, parts.config.train, 0, reward_model=reward, on_progress=mark,
              progress_every=math.gcd(WARMUP, steps))
    end, start = marks[WARMUP + steps], marks[WARMUP]
    return (end[0] - start[0]) / steps, (end[1] - start[1]) / steps


def sb3_loop(steps: int, device: torch.device) -> tuple[float, float]:
    from stable_baselines3.common.callbacks import BaseCallback

    class Timer(BaseCallback):
        def __init__(self):
            super().__init__()
            self.marks = {}

        def _on_step(self) -> bool:
            if self.num_timesteps in (WARMUP, WARMUP + steps):
                self.marks[self.num_timesteps] = time.process_time(), time.perf_counter()
            return True

    timer = Timer()
    sb3_model(steps, device).learn(total_timesteps=WARMUP + steps, callback=timer)
    end, start = timer.marks[WARMUP + steps], timer.marks[WARMUP]
    return (end[0] - start[0]) / steps, (end[1] - start[1]) / steps


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
    parser.add_argument("--steps", type=int, default=4_000, help="timed env steps per loop (>= 4000 includes an update of f)")
    parser.add_argument("--updates", type=int, default=2_000, help="timed calls per update benchmark")
    parser.add_argument("--icvf-steps", type=int, default=3_000)
    parser.add_argument("--skip-sb3", action="store_true")
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    args = parser.parse_args()
    device = torch.device(args.device)
    info = describe_env(ENV_ID)
    gflop = td3_iteration_gflop(info.obs_dim, info.act_dim)
    transitions = random_transitions(ENV_ID)
    updates = {"lwail": lwail_update(args.updates, transitions, device), "plain PyTorch": plain_update(args.updates, transitions, device)}
    steps = {
        "lwail imitation": lwail_loop(args.steps, device, imitation=True),
        "lwail true-reward": lwail_loop(args.steps, device, imitation=False),
        "plain PyTorch": run_plain_td3(ENV_ID, WARMUP, args.steps, cfg.TD3Config(), device=device),
    }
    if not args.skip_sb3:
        updates["Stable-Baselines3"] = sb3_update(args.updates, device)
        steps["Stable-Baselines3"] = sb3_loop(args.steps, device)
    table = []
    for kind, results in (("TD3 update", updates), ("full step", steps)):
        for name, (cpu, wall) in results.items():
            note = f"{1e3 * cpu:.2f} ms CPU, {1e3 * wall:.2f} ms wall" + (f", {gflop / cpu:.0f} GFLOP/s of CPU in TD3 matmuls" if kind == "TD3 update" else "")
            table.append({"measure": f"{kind}: {name} per CPU second", "value": 1 / cpu, "note": note})
        lwail_cpu = results["lwail" if kind == "TD3 update" else "lwail true-reward"][0]
        for name, (cpu, _) in results.items():
            if not name.startswith("lwail"):
                table.append({"measure": f"{kind}: speed-up of lwail vs {name}", "value": cpu / lwail_cpu, "note": "CPU time, baseline / lwail"})
    icvf_rate, plateau_s, plateau_probe, raw_probe = icvf_run(args.icvf_steps, device)
    table += [
        {"measure": "ICVF gradient steps/s", "value": icvf_rate, "note": "batch 256, ensemble of 2, 256-wide (wall)"},
        {"measure": "ICVF seconds to probe plateau", "value": plateau_s, "note": f"probe {plateau_probe:.3f} (raw states {raw_probe:.3f})"},
    ]
    on = torch.cuda.get_device_name(device) if device.type == "cuda" else "CPU"
    machine = f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, {torch.get_num_threads()} threads, on {on}"
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
