"""Every bad input: one line on stderr, exit code 1, no traceback, no artifact written."""

import numpy as np
import pytest

from conftest import committed_versions, write_states_npz


def assert_refused(result, store, before, message):
    assert result.exit_code == 1, result.output
    assert message in result.output
    assert "Traceback" not in result.output
    assert result.output.strip().count("\n") == 0, result.output
    assert committed_versions(store) == before


@pytest.fixture
def seeded(cli, store, tmp_path):
    """A store holding InvertedPendulum demos."""
    write_states_npz(tmp_path / "demos.npz", episodes=2, obs_dim=4, returns=[10.0, 12.0])
    assert cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "demos.npz", "--name", "ip").exit_code == 0
    return committed_versions(store)


@pytest.mark.parametrize(
    "args, message",
    [
        (("collect", "NoSuchEnv-v0"), "unknown environment 'NoSuchEnv-v0'"),
        (("collect", "CartPole-v1"), "Discrete action space"),
        (("collect", "Hopper-v5", "--transitions", "0"), "collect.transitions must be at least 1"),
        (("collect", "Hopper-v5", "--from-minari", "mujoco/hopper/expert-v0"), "not in the local Minari store"),
        (("collect", "Hopper-v5", "--from-minari", "a/b-v0", "--from-file", "x.npz"), "give one source: --from-minari or --from-file ("),
        (("collect", "Hopper-v5", "--from-file", "x.npz", "--transitions", "5"), "--transitions, --start-noise and --seed are for collecting from a random policy;"),
        (("collect", "Hopper-v5", "--from-minari", "a/b-v0", "--seed", "3"), "--transitions, --start-noise and --seed are for collecting from a random policy;"),
        (("demos", "import", "Hopper-v5", "--from-file", "x.npz", "--episodes", "3"), "--episodes, --start-noise and --seed are for --from-sb3 or --planner (a rollout);"),
        (("demos", "import", "Hopper-v5", "--bundled", "--seed", "1"), "--episodes, --start-noise and --seed are for --from-sb3 or --planner (a rollout);"),
        (("expert", "train", "InvertedPendulum-v5", "--steps", "-5"), "train.steps must be at least 1"),
        (("expert", "train", "InvertedPendulum-v5", "--steps", "10", "--resume"), "no checkpoint"),
        (("expert", "record", "missing"), "no policy artifact named 'missing'"),
        (("expert", "record", "ip"), "is a demos artifact, but a policy is needed"),
        (("eval", "ip"), "is a demos artifact, but a policy is needed"),
        (("pretrain-icvf", "ip"), "is a demos artifact, but a dataset is needed"),
        (("imitate", "InvertedPendulum-v5", "--demos", "ip", "--embedding", "nope", "--disc", "x"), "no embedding artifact named 'nope'"),
        (("show", "policy/none"), "no policy artifact named 'none'"),
        # an unknown name says which names exist, or the closest ones
        (("show", "i@v1"), "no artifact named 'i' in store"),
        (("show", "i@v1"), "; did you mean ip?"),
        (("show", "nothing-like-it"), "; artifacts: ip"),
        (("show", "polcy/ip"), "unknown artifact kind 'polcy' in 'polcy/ip'; did you mean policy?"),
        (("expert", "record", "iq"), "no policy artifact named 'iq' in store"),
        (("expert", "record", "iq"), "; there are no policy artifacts yet"),
        (("eval", "demos/iq"), "no demos artifact named 'iq' in store"),
        (("eval", "demos/iq"), "; demos artifacts: ip"),
        (("demos", "import", "Hoper-v5", "--bundled"), "no bundled demos for Hoper-v5; did you mean Hopper-v5?"),
        (("defaults", "imitation"), "unknown stage 'imitation'; did you mean imitate?"),
    ],
)
def test_bad_input_is_one_clear_line(cli, store, seeded, args, message):
    assert_refused(cli(*args), store, seeded, message)


def test_show_finds_a_name_without_its_kind_unless_two_kinds_hold_it(cli, store, seeded, tmp_path):
    shown = cli("show", "ip@v1")
    assert shown.exit_code == 0 and '"kind": "demos"' in shown.output and '"name": "ip"' in shown.output
    write_states_npz(tmp_path / "data.npz", episodes=2, obs_dim=4)
    assert cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "data.npz", "--name", "ip").exit_code == 0
    assert_refused(cli("show", "ip@v1"), store, committed_versions(store),
                   "'ip' names artifacts of 2 kinds: give one of dataset/ip@v1, demos/ip@v1")
    assert '"kind": "dataset"' in cli("show", "dataset/ip").output


def test_demos_with_the_wrong_observation_shape_are_refused(cli, store, seeded, tmp_path):
    write_states_npz(tmp_path / "hopper_like.npz", episodes=2, obs_dim=11)
    result = cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "hopper_like.npz")
    assert_refused(result, store, seeded, "observations have 4 dims")


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda a: a.update(observations=a["observations"] * (1 + 1j)), "must hold real numbers"),
        (lambda a: a.update(episode_ends=np.flatnonzero(a["episode_ends"])), "one flag (bool or 0/1) per observation"),
        (lambda a: a.update(episode_ends=a["episode_ends"] * 7), "one flag (bool or 0/1) per observation"),
        (lambda a: a.update(terminations=np.zeros(5, dtype=bool)), "'terminations' must be one flag"),
        (lambda a: a.update(returns=np.array([1.0, np.inf])), "'returns' must hold one finite number per episode"),
        (lambda a: a.update(returns=np.array([1.0, 2.0, 3.0])), "'returns' must hold one finite number per episode"),
    ],
)
def test_malformed_npz_arrays_are_refused_not_guessed(cli, store, seeded, tmp_path, change, message):
    path = write_states_npz(tmp_path / "d.npz", episodes=2, obs_dim=4, returns=[1.0, 2.0])
    arrays = dict(np.load(path))
    change(arrays)
    np.savez(path, **arrays)
    assert_refused(cli("demos", "import", "InvertedPendulum-v5", "--from-file", path), store, seeded, message)


def test_a_npy_for_a_npz_and_a_store_that_is_a_file_are_one_line(cli, store, seeded, tmp_path, monkeypatch):
    np.save(tmp_path / "x.npy", np.zeros((5, 4)))
    assert_refused(cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "x.npy"), store, seeded, "holds a single array (.npy)")
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("LWAIL_STORE", str(tmp_path / "file"))
    result = cli("demos", "import", "InvertedPendulum-v5", "--bundled")
    assert result.exit_code == 1 and "Not a directory" in result.output and "Traceback" not in result.output
    assert result.output.strip().count("\n") == 0, result.output
    assert (tmp_path / "file").read_text() == ""  # the file standing where the store goes is left as it was


def test_nan_and_empty_data_files_are_refused(cli, store, seeded, tmp_path):
    path = write_states_npz(tmp_path / "nan.npz", episodes=2, obs_dim=4)
    arrays = dict(np.load(path))
    arrays["observations"][3, 1] = np.nan
    np.savez(path, **arrays)
    assert_refused(cli("collect", "InvertedPendulum-v5", "--from-file", path), store, seeded, "NaN")
    (tmp_path / "empty.npz").write_bytes(b"")
    assert_refused(cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "empty.npz"), store, seeded, "cannot read")
    assert_refused(cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "absent.npz"), store, seeded, "no such file")


def test_mismatched_stage_artifacts_are_refused(cli, store, seeded, tmp_path):
    write_states_npz(tmp_path / "data.npz", episodes=3, obs_dim=4)
    assert cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "data.npz", "--name", "ipdata").exit_code == 0
    assert cli("pretrain-icvf", "ipdata", "--kind", "identity", "--name", "ident").exit_code == 0
    assert cli("pretrain-icvf", "ipdata", "--steps", "2", "--embedding-dim", "8", "--set", "icvf.hidden=8", "--name", "icvf").exit_code == 0
    assert cli("warmup-disc", "ident", "ip", "--set", "steps=2", "--name", "disc").exit_code == 0
    before = committed_versions(store)
    stages = ("--demos", "ip", "--embedding", "ident", "--disc", "disc", "--steps", "50")
    assert_refused(cli("warmup-disc", "ident", "ip", "--expert-episodes", "0"), store, before, "expert_episodes must be at least 1")
    assert_refused(cli("imitate", "InvertedPendulum-v5", *stages, "--expert-episodes", "0"), store, before, "expert_episodes must be at least 1")
    assert_refused(cli("imitate", "InvertedPendulum-v5", *stages, "--expert-episodes", "9"), store, before, "holds only 2 episodes")
    assert_refused(cli("imitate", "Hopper-v5", *stages), store, before, "was made for InvertedPendulum-v5, not Hopper-v5")
    mixed = ("--demos", "ip", "--embedding", "icvf", "--disc", "disc", "--steps", "50")
    assert_refused(cli("imitate", "InvertedPendulum-v5", *mixed), store, before, "was warmed up on embedding/ident@v1 (identity)")
    store.runs.save_checkpoint("policy", "run", {"step": 1})
    (store.root / ".runs" / "policy" / "run" / "checkpoint.pt").write_bytes(b"\x00garbage")
    assert_refused(cli("imitate", "InvertedPendulum-v5", *stages, "--name", "run", "--resume"), store, before, "is corrupt")


@pytest.mark.parametrize("name", ["bad\n", "x" * 101, "-lead", "a/b"])
def test_bad_artifact_names_are_refused(cli, store, seeded, tmp_path, name):
    write_states_npz(tmp_path / "d.npz", episodes=2, obs_dim=4)
    assert_refused(cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", name), store, seeded, "artifact name")
