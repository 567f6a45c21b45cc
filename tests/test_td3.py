import sys
from pathlib import Path

import numpy as np
import pytest
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.plain_td3 import PlainTD3  # noqa: E402
from lwail_cli.config import TD3Config, TrainConfig  # noqa: E402
from lwail_cli.envs import describe_env  # noqa: E402
from lwail_cli.replay import ReplayBuffer  # noqa: E402
from lwail_cli.td3 import TD3  # noqa: E402
from lwail_cli.training import RunState, is_better, train_td3  # noqa: E402
from lwail_cli.evaluation import random_policy_return  # noqa: E402
from lwail_cli.rollout import rollout  # noqa: E402
from lwail_cli.seeds import stream_seeds  # noqa: E402


def random_batch(generator, size=64, obs_dim=11, act_dim=3):
    return {
        "observations": torch.randn(size, obs_dim, generator=generator),
        "actions": torch.rand(size, act_dim, generator=generator) * 2 - 1,
        "next_observations": torch.randn(size, obs_dim, generator=generator),
        "rewards": torch.randn(size, 1, generator=generator),
        "not_terminated": (torch.rand(size, 1, generator=generator) > 0.1).float(),
    }


def test_fast_update_equals_textbook_td3():
    env = describe_env("Hopper-v5")
    config = TD3Config(hidden=(32, 32))
    torch.manual_seed(0)
    fast = TD3(env, config)
    plain = PlainTD3(env, config)
    plain.load_from_stacked(fast)
    generator = torch.Generator().manual_seed(1)
    for update in range(6):  # covers delayed actor updates and target updates
        batch = random_batch(generator)
        torch.manual_seed(100 + update)
        fast.update(batch)
        torch.manual_seed(100 + update)
        plain.update(batch)
    for fast_param, plain_param in zip(fast.actor.parameters(), plain.actor.parameters()):
        assert torch.allclose(fast_param, plain_param, atol=1e-6)
    reference = PlainTD3(env, config)
    reference.load_from_stacked(fast)  # fast's stacked critics, unstacked
    for mine, theirs in ((reference.critics, plain.critics), (reference.critics_target, plain.critics_target)):
        for a, b in zip(mine.parameters(), theirs.parameters()):
            assert torch.allclose(a, b, atol=1e-6)
    assert not torch.allclose(fast.actor.net[0].weight, TD3(env, config).actor.net[0].weight)


def test_replay_buffer_wraps_and_reports_recent_rows():
    buffer = ReplayBuffer(5, obs_dim=2, act_dim=1)
    for k in range(7):
        buffer.add(np.full(2, k), np.zeros(1), float(k), np.full(2, k + 1), terminated=(k == 6))
    assert buffer.size == 5 and buffer.count == 7
    assert buffer.storage["rewards"][:, 0].tolist() == [5, 6, 2, 3, 4]
    assert buffer.rows_since(4).tolist() == [4, 0, 1]
    assert buffer.storage["not_terminated"][1, 0] == 0.0
    assert buffer.sample(16)["observations"].shape == (16, 2)
    batch = buffer.sample(64)  # rows of one stored transition each, only from the 5 held (k = 2..6)
    k = batch["rewards"][:, 0]
    assert set(k.tolist()) <= {2.0, 3.0, 4.0, 5.0, 6.0} and len(set(k.tolist())) > 1
    assert torch.equal(batch["observations"], k[:, None].expand(64, 2)) and torch.equal(batch["next_observations"], k[:, None].expand(64, 2) + 1)
    assert torch.equal(batch["not_terminated"][:, 0], (k != 6).float())


@pytest.mark.slow
def test_td3_learns_inverted_pendulum():
    env = describe_env("InvertedPendulum-v5")
    td3 = TD3Config(hidden=(64, 64), random_steps=1000, learning_starts=1000)
    train = TrainConfig(steps=6000, eval_every=6000, eval_episodes=5)
    agent = TD3(env, td3)
    run = train_td3("InvertedPendulum-v5", agent, ReplayBuffer(6000, env.obs_dim, env.act_dim), td3, train, seed=0)
    # holding the cart still keeps the pole up ~24 steps; a uniformly random policy ~4
    still = rollout("InvertedPendulum-v5", lambda obs: np.zeros((len(obs), 1), np.float32), range(10_000, 10_005)).returns.mean()
    assert run.history[-1]["return_mean"] > 1.5 * still > 6 * random_policy_return("InvertedPendulum-v5"), run.history


@pytest.mark.parametrize("kept, other", [("target", "actor"), ("actor", "target")])
def test_the_kept_network_is_evaluated_and_the_other_on_the_same_episodes(kept, other):
    env = describe_env("InvertedPendulum-v5")
    td3 = TD3Config(hidden=(16,), random_steps=300, learning_starts=64, batch_size=64)
    train = TrainConfig(steps=600, eval_every=600, eval_episodes=3, policy=kept)
    torch.manual_seed(0)
    agent = TD3(env, td3)
    run = train_td3("InvertedPendulum-v5", agent, ReplayBuffer(600, env.obs_dim, env.act_dim), td3, train, seed=0)
    seeds = stream_seeds(0, "evaluation", 3)
    row = run.history[-1]
    assert row["return_mean"] == rollout("InvertedPendulum-v5", lambda obs: agent.act(obs, which=kept), seeds).returns.mean()
    assert row[f"{other}_return_mean"] == rollout("InvertedPendulum-v5", lambda obs: agent.act(obs, which=other), seeds).returns.mean()
    assert row["episodes_terminated"] == rollout("InvertedPendulum-v5", lambda obs: agent.act(obs, which=kept), seeds).terminated.sum() > 0
    kept_weights, other_weights = agent.network(kept).state_dict(), agent.network(other).state_dict()
    assert all(torch.equal(run.best_actor[k], kept_weights[k]) for k in kept_weights)
    assert not torch.equal(kept_weights["net.0.weight"], other_weights["net.0.weight"])  # the target trails the actor


def test_without_evaluate_other_only_the_kept_network_is_evaluated():
    env = describe_env("InvertedPendulum-v5")
    td3 = TD3Config(hidden=(16,), random_steps=100, learning_starts=64, batch_size=64)
    train = TrainConfig(steps=100, eval_every=100, eval_episodes=1, evaluate_other=False)
    run = train_td3("InvertedPendulum-v5", TD3(env, td3), ReplayBuffer(100, env.obs_dim, env.act_dim), td3, train, seed=0)
    assert not any(column.startswith(("actor_", "target_")) for column in run.history[-1])


def _short_run(train):
    env = describe_env("InvertedPendulum-v5")
    td3 = TD3Config(hidden=(16,), random_steps=300, learning_starts=64, batch_size=64)
    torch.manual_seed(0)
    agent = TD3(env, td3, average_tau=train.average_tau)
    return agent, train_td3("InvertedPendulum-v5", agent, ReplayBuffer(600, env.obs_dim, env.act_dim), td3, train, seed=0)


def test_a_slower_average_of_the_actor_is_evaluated_and_kept_without_changing_training():
    plain, _ = _short_run(TrainConfig(steps=600, eval_every=300, eval_episodes=2))
    agent, run = _short_run(TrainConfig(steps=600, eval_every=300, eval_episodes=2, average_tau=0.001, policy="average"))
    trained = ("actor", "actor_target", "critic", "critic_target")
    assert all(torch.equal(plain.state_dict()[n][k], agent.state_dict()[n][k]) for n in trained for k in plain.state_dict()[n])
    seeds = stream_seeds(0, "evaluation", 2)
    row = run.history[-1]
    for name, prefix in (("average", ""), ("target", "target_"), ("actor", "actor_")):
        assert row[f"{prefix}return_mean"] == rollout("InvertedPendulum-v5", lambda obs: agent.act(obs, which=name), seeds).returns.mean()
    # after ~270 actor updates the average (τ = 0.001) is still near the initial actor; the target (τ = 0.005) has moved on
    average, target, actor = (agent.network(n).state_dict()["net.0.weight"] for n in ("average", "target", "actor"))
    assert not torch.equal(average, target) and not torch.equal(average, actor)
    assert (average - actor).norm() > (target - actor).norm()  # it trails the actor further than the target does


def test_a_checkpoint_without_the_average_starts_it_at_the_target_actor():
    env = describe_env("InvertedPendulum-v5")
    old = TD3(env, TD3Config(hidden=(16,)))
    with torch.no_grad():
        old.actor_target.net[0].weight.add_(1.0)
    new = TD3(env, TD3Config(hidden=(16,)), average_tau=0.001)
    new.load_state_dict(old.state_dict())
    assert torch.equal(new.network("average").net[0].weight, old.actor_target.net[0].weight)
    assert "actor_average" in new.state_dict() and "actor_average" not in old.state_dict()


def test_keeping_the_average_needs_a_rate():
    from lwail_cli.errors import LwailError

    with pytest.raises(LwailError, match="train.policy=average needs train.average_tau > 0"):
        TrainConfig(policy="average")


def test_an_evaluation_without_a_fall_is_kept_over_a_higher_one_with_a_fall():
    run = RunState()
    assert is_better({"return_mean": 3000.0, "episodes_terminated": 1}, run)  # the first evaluation always
    run.best_actor, run.best_return, run.best_complete = {}, 3000.0, False
    assert is_better({"return_mean": 2500.0, "episodes_terminated": 0}, run)
    run.best_return, run.best_complete = 2500.0, True
    assert not is_better({"return_mean": 4000.0, "episodes_terminated": 2}, run)
    assert not is_better({"return_mean": 2400.0, "episodes_terminated": 0}, run)
    assert is_better({"return_mean": 2600.0, "episodes_terminated": 0}, run)


def test_policy_values_are_the_lower_twin_q_of_the_policy_action():
    env = describe_env("InvertedPendulum-v5")
    torch.manual_seed(0)
    agent = TD3(env, TD3Config(hidden=(16,)))
    states = np.random.default_rng(0).normal(size=(5, env.obs_dim)).astype(np.float32)
    with torch.no_grad():
        for weight in agent.critic.weights[-1]:
            weight.zero_()
        agent.critic.biases[-1].copy_(torch.tensor([3.0, -1.0]).view(2, 1, 1))
    assert torch.equal(agent.policy_values(states), torch.full((5,), -1.0))
    with torch.no_grad():  # twin 0 says 0 everywhere, twin 1 is a trained-looking net: the min is taken per state
        agent.critic.biases[-1].zero_()
        agent.critic.weights[-1][1].normal_()
        inputs = torch.cat([torch.as_tensor(states), agent.actor(torch.as_tensor(states))], 1)
        second = agent.critic(inputs)[1].squeeze(1)
    assert (second > 0).any() and (second < 0).any()
    assert torch.equal(agent.policy_values(states), second.clamp(max=0.0))


def test_each_evaluation_logs_the_critic_values_over_the_evaluated_states():
    env = describe_env("InvertedPendulum-v5")
    td3 = TD3Config(hidden=(16,), random_steps=300, learning_starts=64, batch_size=64)
    train = TrainConfig(steps=600, eval_every=600, eval_episodes=2)
    torch.manual_seed(0)
    agent = TD3(env, td3)
    run = train_td3("InvertedPendulum-v5", agent, ReplayBuffer(600, env.obs_dim, env.act_dim), td3, train, seed=0)
    evaluation = rollout("InvertedPendulum-v5", lambda obs: agent.act(obs, which=train.policy), stream_seeds(0, "evaluation", 2), record=True)
    values = agent.policy_values(np.concatenate([episode.observations for episode in evaluation.episodes]), which=train.policy)
    row = run.history[-1]
    assert row["q_policy_mean"] == float(values.mean()) and row["q_policy_std"] == float(values.std()) > 0
