"""A run's seed gives independent streams: data set I, the online run and the evaluation episodes never coincide."""

import numpy as np
import pytest

from lwail_cli.config import CollectConfig, TD3Config, TrainConfig
from lwail_cli.envs import describe_env
from lwail_cli.replay import ReplayBuffer
from lwail_cli.seeds import STREAMS, stream_seeds
from lwail_cli.stages.collect import collect
from lwail_cli.loaders import load_dataset
from lwail_cli.td3 import TD3
from lwail_cli.training import train_td3


def test_streams_differ_by_use_and_by_seed_and_grow_without_changing():
    firsts = {(seed, stream): stream_seeds(seed, stream)[0] for seed in range(3) for stream in STREAMS}
    assert len(set(firsts.values())) == len(firsts)
    assert not set(stream_seeds(0, "evaluation", 10)) & set(stream_seeds(1, "evaluation", 10))  # seed + i shared 9 of 10
    assert stream_seeds(0, "evaluation", 20)[:10] == stream_seeds(0, "evaluation", 10)  # more episodes keep the first ones
    assert all(0 <= s < 2**32 for s in stream_seeds(2**63, "online", 5))
    with pytest.raises(ValueError):
        stream_seeds(0, "nonsense")


def test_the_online_run_does_not_replay_data_set_one_of_its_seed(store):
    env_id, steps = "Hopper-v5", 200
    dataset = load_dataset(collect(store, env_id=env_id, config=CollectConfig(transitions=steps), seed=0))
    info = describe_env(env_id)
    td3 = TD3Config(hidden=(8,), batch_size=32, random_steps=steps, learning_starts=steps)
    buffer = ReplayBuffer(steps, info.obs_dim, info.act_dim)
    train_td3(env_id, TD3(info, td3), buffer, td3, TrainConfig(steps=steps, eval_every=steps, eval_episodes=1, evaluate_other=False), seed=0)
    online = buffer.storage["observations"][:steps].numpy()
    collected = np.concatenate([episode.observations[:-1] for episode in dataset])[:steps]
    assert online.shape == collected.shape and not np.allclose(online[0], collected[0])
    # not one state in common (a reused reset or action stream would repeat data set I's states exactly)
    distances = np.abs(online[:, None, :] - collected[None, :, :]).max(axis=2)
    assert distances.min() > 1e-6, distances.min()
