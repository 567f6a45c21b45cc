"""`demos import --from-imitation`: trajectories saved by the imitation library, read without decoding or unpickling."""

import json

import numpy as np
import pytest

from lwail_cli import load_episodes
from lwail_cli.stages.demos import bundled_demos_path

ENV = "InvertedPendulum-v5"
# an `infos` entry that jsonpickle.decode would turn into a call of os.system
CODE_IN_INFOS = json.dumps({"py/reduce": [{"py/function": "os.system"}, {"py/tuple": ["touch PWNED"]}]})


def _trajectories(count=3, length=30):
    """Real InvertedPendulum states cut into trajectories, with made-up actions and rewards, as imitation holds them."""
    states = np.load(bundled_demos_path(ENV))["observations"][: count * (length + 1)]
    obs = [states[i * (length + 1) : (i + 1) * (length + 1)] for i in range(count)]
    rews = [np.arange(length, dtype=np.float64) * (i + 1) for i in range(count)]
    acts = [np.zeros((length, 1), np.float32) for _ in range(count)]
    return obs, acts, rews, [True, False, True][:count]


def _save_like_imitation(path, obs, acts, rews, terminal):
    """What imitation.data.serialize.save writes: huggingface_utils.trajectories_to_dict, then datasets' save_to_disk."""
    datasets = pytest.importorskip("datasets")
    infos = [[CODE_IN_INFOS] * len(a) for a in acts]
    datasets.Dataset.from_dict({"obs": obs, "acts": acts, "infos": infos, "terminal": terminal, "rews": rews}).save_to_disk(str(path))


def test_an_imitation_folder_imports_as_state_only_demos_and_nothing_in_it_runs(cli, store, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    obs, acts, rews, terminal = _trajectories()
    _save_like_imitation(tmp_path / "expert", obs, acts, rews, terminal)
    result = cli("demos", "import", ENV, "--from-imitation", tmp_path / "expert", "--name", "im")
    assert result.exit_code == 0, result.output
    demos = store.resolve("im", "demos")
    assert demos.config["source"] == "imitation:expert" and demos.metrics["episodes"] == 3 and demos.metrics["transitions"] == 90
    arrays = load_episodes("demos/im", store.root)
    assert np.array_equal(arrays["observations"], np.concatenate(obs).astype(np.float32))
    assert np.flatnonzero(arrays["episode_ends"]).tolist() == [30, 61, 92]
    assert arrays["terminations"][arrays["episode_ends"]].tolist() == terminal
    returns = np.load(demos.file("demos.npz"))["returns"]
    assert np.allclose(returns, [r.sum() for r in rews])
    assert not (tmp_path / "PWNED").exists()  # the infos were never decoded


def test_imitations_older_npz_imports_without_unpickling(cli, store, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    obs, acts, rews, terminal = _trajectories()
    infos = np.array([{"note": "pickled"}] * 90, dtype=object)  # an object array: reading it would unpickle
    np.savez_compressed(tmp_path / "old.npz", obs=np.concatenate(obs), acts=np.concatenate(acts), infos=infos,
                        terminal=np.array(terminal), rews=np.concatenate(rews), indices=np.cumsum([len(a) for a in acts[:-1]]))
    result = cli("demos", "import", ENV, "--from-imitation", tmp_path / "old.npz", "--name", "old")
    assert result.exit_code == 0, result.output
    arrays = load_episodes("demos/old", store.root)
    assert np.array_equal(arrays["observations"], np.concatenate(obs).astype(np.float32))
    assert arrays["terminations"][arrays["episode_ends"]].tolist() == terminal
    assert np.allclose(np.load(store.resolve("old", "demos").file("demos.npz"))["returns"], [r.sum() for r in rews])


def _bad_folder(tmp_path, change):
    obs, acts, rews, terminal = _trajectories()
    folder = tmp_path / "bad"
    _save_like_imitation(folder, obs, acts, rews, terminal)
    change(folder)
    return folder


def _save_ragged(path):
    datasets = pytest.importorskip("datasets")
    datasets.Dataset.from_dict({"obs": [[[0.0, 1.0, 2.0, 3.0], [0.0, 1.0]]], "terminal": [False]}).save_to_disk(str(path))
    return path


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda tmp: (tmp / "t.pkl").write_bytes(b"\x80\x04K\x01."), "pickled trajectories are never read"),
        (lambda tmp: tmp / "missing", "no such file or folder"),
        (lambda tmp: _bad_folder(tmp, lambda f: (f / "state.json").unlink()), "has no readable state.json"),
        (lambda tmp: _bad_folder(tmp, lambda f: (f / "state.json").write_text('{"_data_files": [{"filename": "../x.arrow"}]}')),
         "must name its data files inside the folder"),
        (lambda tmp: _bad_folder(tmp, lambda f: next(f.glob("*.arrow")).write_bytes(b"not arrow")), "has an unreadable data file"),
        (lambda tmp: _save_ragged(tmp / "ragged"), "every trajectory's 'obs' must be a (T+1, obs_dim) table"),
        (lambda tmp: np.savez(tmp / "o.npz", obs=np.zeros((11, 4)), acts=np.zeros((8, 1)), terminal=np.array([True, False]),
                              indices=np.array([5])), "expected (N, obs_dim) 'obs' holding T+1 rows per trajectory"),
        (lambda tmp: np.savez(tmp / "o.npz", observations=np.zeros((10, 4))), "has no 'obs', 'acts', 'indices', 'terminal'"),
        (lambda tmp: np.savez(tmp / "o.npz", obs=np.zeros((10, 3)), acts=np.zeros((9, 1)), terminal=np.array([True]),
                              indices=np.array([], dtype=np.int64)), "observations have 4 dims"),
    ],
)
def test_a_bad_imitation_input_is_one_clear_line(cli, store, tmp_path, make, message):
    made = make(tmp_path)
    path = made if hasattr(made, "exists") else next(p for p in tmp_path.iterdir() if p.name != "store")
    result = cli("demos", "import", ENV, "--from-imitation", path)
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert result.output.strip().count("\n") == 0, result.output
    assert store.list() == []


def test_without_pyarrow_a_folder_says_how_to_install_it(cli, store, tmp_path, monkeypatch):
    import sys

    obs, acts, rews, terminal = _trajectories()
    _save_like_imitation(tmp_path / "expert", obs, acts, rews, terminal)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    result = cli("demos", "import", ENV, "--from-imitation", tmp_path / "expert")
    assert result.exit_code == 1 and 'pip install "lwail[imitation]"' in result.output, result.output
    assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
    assert store.list() == []
