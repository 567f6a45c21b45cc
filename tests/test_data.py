import minari
import numpy as np
import pytest

from lwail_cli.config import CollectConfig
from lwail_cli.data import flatten, transition_pairs
from lwail_cli.envs import make_env
from lwail_cli.errors import LwailError
from lwail_cli.formats.npz import read_npz, write_npz
from lwail_cli.rollout import rollout
from lwail_cli.stages.collect import collect
from lwail_cli.loaders import load_dataset


def random_episodes(env_id, transitions, seed):
    return rollout(env_id, None, [seed], record=True, transitions=transitions).episodes


def test_collect_keeps_boundaries_and_loads_with_minari(store):
    artifact = collect(store, env_id="Hopper-v5", config=CollectConfig(transitions=600), seed=1)
    dataset = minari.MinariDataset(artifact.file("minari"))
    assert dataset.total_steps == 600
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == artifact.metrics["episodes"] > 5  # a random Hopper falls within ~20-40 steps
    for episode in episodes[:-1]:  # each finished episode ends in a fall (termination), not a truncation
        assert episode.terminations[-1] and not episode.truncations.any()
        assert not episode.terminations[:-1].any()
        assert len(episode.observations) == len(episode.actions) + 1
    last = episodes[-1]  # cut by the transition budget: a truncation, not a termination
    assert last.truncations[-1] and not last.terminations.any()
    loaded = load_dataset(artifact)
    assert [e.terminated for e in loaded] == [True] * (len(loaded) - 1) + [False]
    assert np.allclose(loaded[0].observations, episodes[0].observations)


def test_collect_into_the_default_relative_store(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("LWAIL_STORE", raising=False)
    from lwail_cli.artifacts import Store

    artifact = collect(Store(), env_id="InvertedPendulum-v5", config=CollectConfig(transitions=50), seed=0)
    assert artifact.path == tmp_path / "artifacts" / "dataset" / "invertedpendulum-v5-random" / "v1"
    assert minari.MinariDataset(artifact.file("minari")).total_steps == 50


def test_pairs_never_cross_episode_boundaries():
    episodes = random_episodes("Hopper-v5", 300, seed=0)
    states, successors = transition_pairs(episodes)
    assert len(states) == 300
    flat = flatten(episodes)
    assert flat.has_successor.sum() == 300
    first_of_second = episodes[1].observations[0]
    assert not any(np.allclose(s, first_of_second) for s in successors[: episodes[0].length])
    # pair k is (s_t, s_t+1) of one episode: each episode's pairs in order, none from its last state or to a first one
    assert len(episodes) > 2 and states.shape == successors.shape == (300, 11)
    start = 0
    for episode in episodes:
        observations = episode.observations.astype(np.float32)
        assert np.array_equal(states[start : start + episode.length], observations[:-1])
        assert np.array_equal(successors[start : start + episode.length], observations[1:])
        start += episode.length
    firsts = np.stack([episode.observations[0] for episode in episodes]).astype(np.float32)
    assert not (successors[:, None, :] == firsts[None, :, :]).all(axis=2).any()
    ends = np.cumsum([len(episode.observations) for episode in episodes]) - 1
    assert np.flatnonzero(~flat.has_successor).tolist() == ends.tolist()
    assert np.array_equal(flat.observations[flat.has_successor], states)


def test_npz_round_trip_keeps_episodes_terminations_and_returns(tmp_path):
    episodes = random_episodes("InvertedPendulum-v5", 120, seed=0)
    returns = np.array([e.episode_return for e in episodes])
    write_npz(tmp_path / "d.npz", episodes, returns)
    loaded, loaded_returns = read_npz(tmp_path / "d.npz")
    assert [len(e.observations) for e in loaded] == [len(e.observations) for e in episodes]
    assert [e.terminated for e in loaded] == [e.terminated for e in episodes]
    assert np.allclose(loaded_returns, returns)


@pytest.mark.parametrize(
    "arrays, message",
    [
        ({"observations": np.zeros((0, 4)), "episode_ends": np.zeros(0, bool)}, "non-empty"),
        ({"observations": np.zeros((5, 4))}, "no 'episode_ends'"),
        ({"observations": np.zeros((5, 4)), "episode_ends": np.array([0, 0, 1, 0, 0], bool)}, "last observation"),
    ],
)
def test_malformed_npz_files_are_refused(tmp_path, arrays, message):
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(LwailError, match=message):
        read_npz(tmp_path / "bad.npz")


def test_import_from_the_local_minari_store_keeps_reference_scores(store, tmp_path, monkeypatch):
    from minari.data_collector import EpisodeBuffer

    from lwail_cli.stages.demos import import_demos
    from lwail_cli.stages.shared import reference_for_env

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    env = make_env("InvertedPendulum-v5")
    buffers = []
    for index, episode in enumerate(random_episodes("InvertedPendulum-v5", 60, seed=0)):
        n = episode.length
        buffers.append(EpisodeBuffer(id=index, observations=episode.observations.astype(np.float64), actions=episode.actions,
                                     rewards=list(episode.rewards), terminations=[False] * (n - 1) + [episode.terminated],
                                     truncations=[False] * (n - 1) + [not episode.terminated]))
    minari.create_dataset_from_buffers("lwail/ip-test-v0", buffers, env="InvertedPendulum-v5", ref_min_score=5.0, ref_max_score=1005.0,
                                       algorithm_name="random", author="t", author_email="t", code_permalink="t", description="t")
    demos = import_demos(store, env_id="InvertedPendulum-v5", minari_id="lwail/ip-test-v0")
    assert demos.metrics["episodes"] == len(buffers) and demos.metrics["ref_max_score"] == 1005.0
    reference = reference_for_env("InvertedPendulum-v5", demos)
    assert reference.normalize(505.0) == pytest.approx(50.0) and "Minari refs" in reference.source
