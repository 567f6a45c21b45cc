"""Stable-Baselines3 interop: SB3 models are played without unpickling them; lwail policies load in SB3's TD3."""

import os
import zipfile

import numpy as np
import pytest
import torch

from lwail_cli.envs import describe_env
from lwail_cli.errors import LwailError
from lwail_cli.formats.sb3_zip import read_sb3_policy

sb3 = pytest.importorskip("stable_baselines3")
ENV = "InvertedPendulum-v5"


def _observations(n=32):
    return np.random.default_rng(0).normal(size=(n, 4)).astype(np.float32)


@pytest.mark.parametrize("algorithm", ["TD3", "SAC", "PPO", "A2C"])
def test_an_sb3_model_plays_like_sb3_predict(tmp_path, algorithm):
    kwargs = {"net_arch": [16, 16]}
    if algorithm == "PPO":
        kwargs["activation_fn"] = torch.nn.ReLU  # a non-default activation is read from the readable JSON
    model = getattr(sb3, algorithm)("MlpPolicy", ENV, policy_kwargs=kwargs, device="cpu", seed=0)
    if algorithm in ("PPO", "A2C"):  # random init gives ~0 actions: move the head so clipping is exercised too
        with torch.no_grad():
            model.policy.action_net.bias.fill_(2.5)
    model.save(tmp_path / "model.zip")
    act = read_sb3_policy(tmp_path / "model.zip", describe_env(ENV))
    expected, _ = model.predict(_observations(), deterministic=True)
    assert np.allclose(act(_observations()), expected, atol=1e-5)


def test_demos_import_from_sb3_and_export_round_trip(cli, store, tmp_path):
    model = sb3.TD3("MlpPolicy", ENV, policy_kwargs={"net_arch": [16, 16]}, device="cpu", seed=0)
    model.save(tmp_path / "expert.zip")
    result = cli("demos", "import", ENV, "--from-sb3", tmp_path / "expert.zip", "--episodes", "2", "--name", "sb3demos")
    assert result.exit_code == 0, result.output
    demos = store.resolve("sb3demos", "demos")
    assert demos.metrics["episodes"] == 2 and demos.config["source"] == "sb3:expert.zip"

    trained = cli("expert", "train", ENV, "--steps", "400", "--eval-every", "400", "--set", "td3.random_steps=300",
                  "--set", "td3.learning_starts=300", "--set", "td3.hidden=(16,16)", "--name", "p")
    assert trained.exit_code == 0, trained.output
    assert cli("export", "p", "--out", tmp_path / "p.zip").exit_code == 0
    import lwail_cli

    ours, _ = lwail_cli.load_policy("p", store=store.root).predict(_observations())
    theirs, _ = sb3.TD3.load(tmp_path / "p.zip", device="cpu").predict(_observations(), deterministic=True)
    assert np.allclose(ours, theirs, atol=1e-5)


class Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_pickle_in_a_model_zip_never_runs(tmp_path):
    marker = tmp_path / "pwned"
    model = sb3.TD3("MlpPolicy", ENV, policy_kwargs={"net_arch": [16, 16]}, device="cpu")
    model.save(tmp_path / "model.zip")
    with zipfile.ZipFile(tmp_path / "model.zip") as original, zipfile.ZipFile(tmp_path / "evil.zip", "w") as evil:
        for item in original.namelist():
            if item != "policy.pth":
                evil.writestr(item, original.read(item))
        with evil.open("policy.pth", "w") as handle:
            torch.save({"actor.mu.0.weight": Payload(marker)}, handle)
    with pytest.raises(LwailError, match="is not a Stable-Baselines3 model.zip"):
        read_sb3_policy(tmp_path / "evil.zip", describe_env(ENV))
    assert not marker.exists()
    with pytest.raises(LwailError, match="observations have 11 dims"):
        read_sb3_policy(tmp_path / "model.zip", describe_env("Hopper-v5"))
