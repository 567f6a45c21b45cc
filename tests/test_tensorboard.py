"""`lwail --tensorboard DIR`: the figures of long stages as TensorBoard scalars, the CSV's evaluation rows included."""

import pandas as pd
import pytest

from conftest import write_states_npz


def _scalars(folder):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    (run,) = [path for path in folder.iterdir()]
    events = EventAccumulator(str(run))
    events.Reload()
    return {tag: [(e.step, e.value) for e in events.Scalars(tag)] for tag in events.Tags()["scalars"]}, run.name


def test_an_online_run_logs_its_curve_rows_as_scalars(cli, store, tmp_path):
    pytest.importorskip("tensorboard")
    result = cli("--tensorboard", tmp_path / "tb", "expert", "train", "InvertedPendulum-v5", "--steps", "400", "--eval-every", "200",
                 "--set", "td3.random_steps=300", "--set", "td3.learning_starts=300", "--set", "td3.hidden=(16,16)", "--name", "p")
    assert result.exit_code == 0, result.output
    scalars, run = _scalars(tmp_path / "tb")
    assert run.startswith("expert_InvertedPendulum-v5-")
    curve = pd.read_csv(store.resolve("p", "policy").file("learning_curve.csv"))
    logged = scalars["curve/return_mean"]
    assert [step for step, _ in logged] == curve["step"].tolist() == [200, 400]
    assert [value for _, value in logged] == pytest.approx(curve["return_mean"].tolist())
    assert "ep_return" in scalars


def test_pretraining_logs_its_loss(cli, store, tmp_path):
    pytest.importorskip("tensorboard")
    write_states_npz(tmp_path / "d.npz", episodes=6, obs_dim=4)
    assert cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", "data").exit_code == 0
    result = cli("--tensorboard", tmp_path / "tb", "pretrain-icvf", "data", "--set", "icvf.steps=20", "--set", "icvf.log_every=10",
                 "--set", "icvf.hidden=(16,)", "--set", "icvf.embedding_dim=8", "--name", "e")
    assert result.exit_code == 0, result.output
    scalars, _ = _scalars(tmp_path / "tb")
    assert [step for step, _ in scalars["loss"]][-1] == 20
    logged = pd.read_csv(store.resolve("e", "embedding").file("loss.csv"))  # each row of loss.csv, the same loss
    assert [step for step, _ in scalars["loss"]] == logged["step"].tolist() == [10, 20]
    assert [value for _, value in scalars["loss"]] == pytest.approx(logged["loss"].tolist(), rel=1e-6)
