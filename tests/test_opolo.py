"""OPOLO (methods/opolo.py): its critic and actor losses are OPOLO's objective and reach the networks they should,
the inverse-action regulariser pulls the actor onto g's demo actions, and the initial-value term holds the critic's
value of the policy's actions down (the end-to-end runs and the resume bit for bit: tests/test_methods.py)."""

import pytest
import torch

from lwail_cli import config as cfg
from lwail_cli.envs import describe_env
from lwail_cli.methods.opolo import OpoloTD3

ENV = describe_env("InvertedPendulum-v5")  # 4 states, 1 action in [-3, 3]
CPU = torch.device("cpu")


def _agent(alpha: float, regularization: float, gamma: float = 0.99, seed: int = 0) -> OpoloTD3:
    torch.manual_seed(seed)
    demo_states = torch.randn(50, ENV.obs_dim)
    agent = OpoloTD3(ENV, cfg.TD3Config(hidden=(32, 32), actor_lr=1e-3, batch_size=64, gamma=gamma, learning_starts=64, policy_delay=1), CPU,
                     average_tau=0.0, opolo=cfg.OpoloConfig(alpha=alpha, regularization=regularization), demo_states=demo_states)
    agent.demo_actions = 0.8 * torch.tanh(demo_states[:, :1] - demo_states[:, 1:2])  # what g would infer, in [-1, 1] units
    return agent


def _batch(rows: int = 64, seed: int = 1) -> dict[str, torch.Tensor]:
    generator = torch.Generator().manual_seed(seed)
    return {"observations": torch.randn(rows, ENV.obs_dim, generator=generator),
            "actions": torch.rand(rows, ENV.act_dim, generator=generator) * 6 - 3,
            "next_observations": torch.randn(rows, ENV.obs_dim, generator=generator),
            "rewards": torch.zeros(rows, 1), "not_terminated": torch.ones(rows, 1)}


def test_the_losses_are_opolos_objective_and_each_reaches_only_its_own_network():
    agent = _agent(alpha=0.3, regularization=0.7, gamma=0.9)
    weight = 2 * 0.3 * (1 - 0.9)
    obs, actions = _batch()["observations"], _batch()["actions"]
    target = torch.randn(64, 1)
    q = agent.critic(torch.cat([obs, actions], 1))
    loss = agent.critic_loss(obs, q, target)
    twins_on_policy = agent.critic(torch.cat([obs, agent.actor(obs)], 1))  # (2, rows, 1)
    expected = 0.5 * ((q[0] - target).square().mean() + (q[1] - target).square().mean()) + weight * torch.minimum(*twins_on_policy).mean()
    assert loss.item() == pytest.approx(expected.item(), rel=1e-6)
    loss.backward()
    assert all(p.grad is None for p in agent.actor.parameters())  # the policy's actions are held fixed in the critic's loss
    agent.critic.zero_grad(set_to_none=True)

    torch.manual_seed(7)
    loss = agent.actor_loss(obs)
    torch.manual_seed(7)
    index = torch.randint(0, 50, (64,))
    error = (torch.tanh(agent.actor.net(agent.demo_states[index])) - agent.demo_actions[index]).square().mean()
    expected = -weight * torch.minimum(*agent.critic(torch.cat([obs, agent.actor(obs)], 1))).mean() + 0.7 * error
    assert loss.item() == pytest.approx(expected.item(), rel=1e-6)
    assert agent.last_regularizer.item() == pytest.approx(error.item(), rel=1e-6)
    loss.backward()
    assert all(p.grad is None for p in agent.critic.parameters())  # the actor reads the critic, never trains it
    assert all(p.grad is not None for p in agent.actor.parameters())


def test_the_regulariser_alone_clones_gs_actions_and_without_it_or_alpha_the_actor_stays():
    cloning = _agent(alpha=0.0, regularization=1.0)
    before = cloning.actor.state_dict()
    before = {name: tensor.clone() for name, tensor in before.items()}

    def demo_error(agent):
        return (torch.tanh(agent.actor.net(agent.demo_states)) - agent.demo_actions).square().mean().item()

    start = demo_error(cloning)
    for step in range(400):
        cloning.update(_batch(seed=step))
    assert demo_error(cloning) < 0.1 * start, (start, demo_error(cloning))

    still = _agent(alpha=0.0, regularization=0.0)
    for step in range(50):
        still.update(_batch(seed=step))
    # TD3's −Q₁ is gone from the actor's loss: with both of OPOLO's weights at 0 nothing moves it
    assert all(torch.equal(before[name], tensor) for name, tensor in still.actor.state_dict().items())


def test_the_initial_value_term_holds_the_critics_value_of_the_policys_actions_down():
    """Zero rewards: TD alone leaves Q near 0; the 2α(1−γ)·E[min Q(s, π(s))] term pushes it below."""
    values = {}
    for alpha in (0.0, 20.0):
        agent = _agent(alpha=alpha, regularization=1.0)
        for step in range(300):
            agent.update(_batch(seed=step))
        obs = _batch(seed=10_000)["observations"]
        with torch.no_grad():
            values[alpha] = torch.minimum(*agent.critic(torch.cat([obs, agent.actor(obs)], 1))).mean().item()
    assert abs(values[0.0]) < 0.5 and values[20.0] < values[0.0] - 1.0, values
