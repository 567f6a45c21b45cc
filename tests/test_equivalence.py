"""One update of each fast path equals one update of its textbook version from the same weights and batch."""

import copy
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.plain_discriminator import plain_critic_step  # noqa: E402
from benchmarks.plain_icvf import PlainICVF  # noqa: E402
from lwail_cli.config import CriticConfig, ICVFConfig  # noqa: E402
from lwail_cli.data import Episode  # noqa: E402
from lwail_cli.discriminator import Critic, DiscriminatorTrainer  # noqa: E402
from lwail_cli.icvf import GoalSampler, ICVFLearner  # noqa: E402


@pytest.mark.parametrize("layer_norm", ["none", "after", "before"])
def test_fast_icvf_update_equals_textbook_icvf(layer_norm):
    config = ICVFConfig(hidden=(16,), embedding_dim=16, layer_norm=layer_norm)
    rng = np.random.default_rng(0)
    episodes = [Episode(observations=rng.normal(size=(12, 5)).astype(np.float32)) for _ in range(6)]
    torch.manual_seed(0)
    fast = ICVFLearner(5, config)
    with torch.no_grad():  # make the target differ from the online net, as it does mid-training
        for param in fast.target.parameters():
            param.add_(0.05 * torch.randn_like(param))
    plain = PlainICVF(5, config)
    plain.load_from_stacked(fast)
    sampler = GoalSampler(episodes, config, torch.device("cpu"))
    for _ in range(3):
        batch = sampler.sample(32)
        fast.update(batch)
        plain.update(batch)
    check = PlainICVF(5, config)
    check.load_from_stacked(fast)
    for mine, theirs in ((check.members, plain.members), (check.targets, plain.targets)):
        for a, b in zip(mine.parameters(), theirs.parameters()):
            assert torch.allclose(a, b, atol=1e-5), (a - b).abs().max()


@pytest.mark.parametrize("tanh", [True, False])
def test_fast_discriminator_update_equals_textbook_wgan_gp(tanh):
    config = CriticConfig(hidden=(16, 16), tanh=tanh)
    torch.manual_seed(0)
    critic = Critic(6, config.hidden)
    plain = copy.deepcopy(critic)
    trainer = DiscriminatorTrainer(critic, config)
    optimizer = torch.optim.Adam(plain.parameters(), lr=config.lr)
    expert, policy = torch.randn(50, 6), torch.randn(50, 6) + 1
    for step in range(4):
        torch.manual_seed(step)
        trainer.train(expert, policy, 1)
        torch.manual_seed(step)
        index = torch.randint(0, expert.shape[0], (policy.shape[0],))  # the same expert draw
        plain_critic_step(plain, optimizer, expert[index], policy, config.gp_weight, config.tanh)
    for a, b in zip(critic.parameters(), plain.parameters()):
        assert torch.allclose(a, b, atol=1e-6)
    assert not torch.allclose(next(critic.parameters()), next(Critic(6, config.hidden).parameters()))
