"""The demos shipped with lwail: each imports for its env and agrees with what experts.json says of its expert."""

import json
from importlib import resources

import numpy as np
import pytest
from lwail_cli.envs import describe_env
from lwail_cli.evaluation import d4rl_reference
from lwail_cli.stages import demos

BUNDLE = resources.files("lwail_cli") / "demos"
EXPERTS = json.loads((BUNDLE / "experts.json").read_text())
ENVS = sorted(path.name[:-4] for path in BUNDLE.iterdir() if path.name.endswith(".npz"))


def test_every_bundled_demos_file_has_its_expert_described():
    assert ENVS == sorted(EXPERTS)
    assert {"InvertedPendulum-v5", "Hopper-v5"} <= set(ENVS)


@pytest.mark.parametrize("env_id", ENVS)
def test_bundled_demos_import_and_match_their_expert(store, env_id):
    artifact = demos.import_bundled_demos(store, env_id=env_id)
    expert = EXPERTS[env_id]
    assert artifact.env.obs_dim == describe_env(env_id).obs_dim
    assert artifact.metrics["episodes"] == expert["episodes"] == 10
    assert artifact.metrics["mean_return"] == pytest.approx(expert["mean_return"])
    with np.load(demos.bundled_demos_path(env_id)) as bundle:
        assert bundle["observations"].dtype == np.float32  # the wheel stays small
    reference = d4rl_reference(env_id)
    if reference is not None:
        assert expert["d4rl_normalized"] == pytest.approx(reference.normalize(expert["mean_return"]))
