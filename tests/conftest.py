import os

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from lwail_cli.artifacts import Store
from lwail_cli.cli import app


@pytest.fixture(autouse=True)
def _few_threads():
    # LWAIL_TEST_THREADS=1 when a long run shares the machine (two 2-thread torch processes on 2 cores crawl)
    torch.set_num_threads(int(os.environ.get("LWAIL_TEST_THREADS", "2")))


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("LWAIL_STORE", str(tmp_path / "store"))
    return Store(tmp_path / "store")


@pytest.fixture
def cli(store):
    runner = CliRunner()

    def invoke(*args):
        return runner.invoke(app, [str(a) for a in args])

    return invoke


def committed_versions(store: Store) -> list:
    return [(kind, name, versions) for kind, name, versions, _ in store.list()]


def write_states_npz(path, episodes, obs_dim, length=20, seed=0, returns=None):
    rng = np.random.default_rng(seed)
    observations = rng.normal(size=(episodes * length, obs_dim)).astype(np.float32)
    ends = np.zeros(len(observations), dtype=bool)
    ends[length - 1 :: length] = True
    arrays = {"observations": observations, "episode_ends": ends}
    if returns is not None:
        arrays["returns"] = np.asarray(returns, dtype=np.float64)
    np.savez(path, **arrays)
    return path


def demos_and_identity(store: Store, env_id: str, transitions: int) -> None:
    """The bundled demos as "ip", data set I of ``transitions`` uniformly random steps (with their actions) and the
    identity embedding "ident" on it: what a method that reads no warmed-up discriminator runs on."""
    from lwail_cli import config as cfg
    from lwail_cli.stages import collect, demos, embed

    demos.import_bundled_demos(store, env_id=env_id, name="ip")
    data = collect.collect(store, env_id=env_id, config=cfg.CollectConfig(transitions=transitions), seed=0)
    embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, name="ident", device=torch.device("cpu"))
