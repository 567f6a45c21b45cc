"""DIFO's diffusion discriminator (methods/difo.py): the cosine noise schedule by its closed form, the noise steps the
training loss and the reward draw, the denoiser learning under the expert's label, and D telling expert pairs from
policy pairs; its settings refused in one line. End to end and resume: tests/test_methods.py."""

import math

import pytest
import torch

from lwail_cli import config as cfg
from lwail_cli.errors import LwailError
from lwail_cli.methods.difo import DiffusionDiscriminator, DifoTrainer, cosine_alpha_bars

SMALL = dict(hidden=(64, 64), embedding=16)


def _pairs(rows: int, step: float, seed: int) -> torch.Tensor:
    """Features [s, s′ − s] of 2-d states in [−1, 1] that all move by ``step`` in each dimension."""
    states = torch.rand(rows, 2, generator=torch.Generator().manual_seed(seed)) * 2.0 - 1.0
    return torch.cat([states, torch.full_like(states, step)], dim=-1)


def test_the_cosine_schedule_telescopes_to_its_closed_form():
    alpha_bars = cosine_alpha_bars(1000).double()

    def closed(u: float) -> float:
        return math.cos((u / 1000 + 0.008) / 1.008 * math.pi / 2) ** 2

    # no β reaches the 0.999 cap before the last steps, so ᾱ_t = ᾱ(t + 1) / ᾱ(0)
    for t in (0, 249, 499, 749, 900):
        assert alpha_bars[t].item() == pytest.approx(closed(t + 1) / closed(0), rel=1e-5)
    assert alpha_bars[499].item() == pytest.approx(0.4938, abs=1e-4)
    assert bool((alpha_bars[1:] < alpha_bars[:-1]).all()) and alpha_bars[-1].item() < 1e-6


def test_training_draws_every_noise_step_and_the_reward_only_the_middle_ones(monkeypatch):
    torch.manual_seed(0)
    discriminator = DiffusionDiscriminator(4, cfg.DifoConfig(**SMALL))
    drawn = []
    forward = discriminator.denoiser.forward
    monkeypatch.setattr(discriminator.denoiser, "forward", lambda noisy, times, labels, states: drawn.append(times) or forward(noisy, times, labels, states))
    pairs = _pairs(2048, 0.1, seed=0)
    discriminator(pairs)
    DifoTrainer(discriminator, cfg.DifoConfig(**SMALL)).loss(pairs, pairs)
    reward_times, training_times = drawn
    assert 250 <= reward_times.min() and reward_times.max() < 750 and reward_times.shape == (2 * 2048,)
    assert training_times.min() < 50 and training_times.max() > 950


def test_the_denoiser_learns_the_expert_pairs_under_the_expert_label():
    torch.manual_seed(0)
    config = cfg.DifoConfig(**SMALL, lr=1e-3, bce_weight=0.0)  # the denoising loss alone
    discriminator = DiffusionDiscriminator(4, config)
    expert = _pairs(512, 0.5, seed=1)
    discriminator.fit_range(expert)
    trainer = DifoTrainer(discriminator, config)
    with torch.no_grad():
        before = discriminator.errors(expert, 0, 1000)[1].mean()
    trainer.train(expert, _pairs(512, -0.5, seed=2), 300)
    with torch.no_grad():
        after = discriminator.errors(expert, 0, 1000)[1].mean()
    # predicting no noise at all scores 1 (the noise's variance); the trained model does far better
    assert before > 0.8 and after < 0.5 * before


def test_d_rewards_expert_pairs_above_policy_pairs_once_trained():
    torch.manual_seed(0)
    config = cfg.DifoConfig(**SMALL, lr=1e-3, bce_weight=1.0)
    discriminator = DiffusionDiscriminator(4, config)
    expert, policy = _pairs(512, 0.5, seed=1), _pairs(512, -0.5, seed=2)
    discriminator.fit_range(torch.cat([expert, policy]))
    trainer = DifoTrainer(discriminator, config)
    trainer.train(expert, policy, 1)
    untrained = trainer.estimate()["discriminator_loss"]
    trainer.train(expert, policy, 300)
    # −log(1 − D) is log 2 where D cannot tell a pair apart
    assert trainer.reward(expert).mean() > 2.0 > math.log(2.0) > 0.2 > trainer.reward(policy).mean() >= 0.0
    assert trainer.estimate()["discriminator_loss"] < 0.5 * untrained


def test_the_fitted_range_scales_phi_to_minus_one_one():
    discriminator = DiffusionDiscriminator(4, cfg.DifoConfig(**SMALL))
    pairs = _pairs(256, 0.5, seed=3) * 7.0
    discriminator.fit_range(pairs)
    phi, step = pairs.chunk(2, dim=-1)
    scaled = discriminator.scaled(torch.cat([phi, phi + step]))
    assert torch.allclose(scaled.min(dim=0).values, -torch.ones(2)) and torch.allclose(scaled.max(dim=0).values, torch.ones(2))


@pytest.mark.parametrize("overrides, message", [
    (["difo.embedding=33"], "difo.embedding must be even"),
    (["difo.reward_t_high=1001"], "difo.reward_t_low < difo.reward_t_high <= difo.diffusion_steps must hold, got 250, 1001, 1000"),
    (["difo.reward_t_low=750"], "got 750, 750, 1000"),
])
def test_bad_difo_settings_are_refused_in_one_line(overrides, message):
    with pytest.raises(LwailError, match=message):
        cfg.with_overrides(cfg.ImitationConfig(method="difo"), overrides)
