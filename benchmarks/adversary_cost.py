"""What one adversary costs on LWAIL's schedule: LWAIL's critic f, GAIfO's D and DIFO's diffusion D.

    OMP_NUM_THREADS=1 python -m benchmarks.adversary_cost [--buffer 100000]

For each adversarial method and two feature widths (the identity φ of Hopper-v5, 2 × 11; the ICVF φ, 2 × 256), in
CPU seconds of one thread (what a run pays on a shared machine, where wall time mostly measures the scheduler): one
update window's training (``update_steps`` = 40 full-batch steps on 4,000 policy pairs against as many expert pairs,
the defaults) and the reward of a full 1M-pair replay buffer (timed on ``--buffer`` pairs and scaled), which the
window's relabel pays once the buffer is full. Random features and fresh weights: the cost of a step does not depend
on what the networks have learned.
"""

from __future__ import annotations

import argparse
import time

import torch

from lwail_cli import config as cfg
from lwail_cli.discriminator import Critic, DiscriminatorTrainer
from lwail_cli.methods.difo import DiffusionDiscriminator, DifoTrainer
from lwail_cli.methods.gaifo import GaifoTrainer

WIDTHS = {"identity φ of Hopper-v5": 22, "ICVF φ": 512}  # the pair features [φ(s), φ(s′) − φ(s)]
FULL_BUFFER = 1_000_000


def adversaries(width: int) -> dict:
    critic = cfg.CriticConfig()
    return {
        "lwail": DiscriminatorTrainer(Critic(width, critic.hidden), critic),
        "gaifo": GaifoTrainer(Critic(width, cfg.GaifoConfig().hidden), cfg.GaifoConfig()),
        "difo": DifoTrainer(DiffusionDiscriminator(width, cfg.DifoConfig()), cfg.DifoConfig()),
    }


def cpu_seconds(call) -> float:
    start = time.process_time()
    call()
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buffer", type=int, default=100_000, help="buffered pairs rewarded (timed, then scaled to 1M)")
    args = parser.parse_args()
    torch.manual_seed(0)
    config = cfg.ImitationConfig()
    print(f"torch threads {torch.get_num_threads()}; update window {config.update_every} env steps, {config.update_steps} updates")
    print(f"| φ | method | one window's updates, s CPU | reward of 1M buffered pairs, s CPU |\n| --- | --- | ---: | ---: |")
    for phi, width in WIDTHS.items():
        expert, policy, buffer = torch.randn(1_000, width), torch.randn(config.update_every, width), torch.randn(args.buffer, width)
        for method, trainer in adversaries(width).items():
            train = cpu_seconds(lambda: trainer.train(expert, policy, config.update_steps))
            relabel = cpu_seconds(lambda: trainer.reward(buffer)) * FULL_BUFFER / args.buffer
            print(f"| {phi} | {method} | {train:.1f} | {relabel:.1f} |")


if __name__ == "__main__":
    main()
