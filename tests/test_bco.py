"""BCO (methods/bco.py, inverse_dynamics.py): the inverse-dynamics model recovers the actions of a known system, its
standardiser is the reference's, cloning the inferred actions beats the untrained policy on InvertedPendulum-v5,
the CLI runs it end to end (then `eval` and `curve`), and what it cannot run on is refused in one line."""

import numpy as np
import pandas as pd
import pytest
import torch

from conftest import committed_versions, demos_and_identity, write_states_npz
from lwail_cli import config as cfg
from lwail_cli import learning_curve
from lwail_cli.inverse_dynamics import STD_FLOOR, InverseDynamics, RunningStandardizer
from lwail_cli.methods import METHODS
from lwail_cli.stages import collect, demos, embed, imitate

ENV = "InvertedPendulum-v5"
CPU = torch.device("cpu")


def test_the_inverse_dynamics_model_recovers_the_actions_of_a_known_system():
    """s' = s + B·a + 0.1·sin(s) with a random B (3 states, 2 actions, full column rank): the action is a function of
    the pair, and the model must find it from uniformly random actions, as from data set I."""
    generator = torch.Generator().manual_seed(0)
    torch.manual_seed(0)
    mixing = torch.randn(2, 3, generator=generator)

    def pairs(n):
        states = torch.randn(n, 3, generator=generator)
        actions = torch.rand(n, 2, generator=generator) * 2 - 1  # already in [-1, 1] units
        following = states + actions @ mixing + 0.1 * torch.sin(states)
        return torch.cat([states, following - states], 1), actions  # the identity φ's pair features

    model = InverseDynamics(6, 2, cfg.BcoConfig(idm_hidden=(64, 64), idm_lr=1e-3, idm_weight_decay=1e-5), CPU)
    features, actions = pairs(4096)
    for step in range(1500):
        batch = torch.randint(0, len(features), (128,), generator=generator)
        model.step(features[batch], actions[batch])
    held_out, truth = pairs(1000)
    error = (model.infer(held_out) - truth).square().mean().item()
    guessing_zero = truth.square().mean().item()  # 1/3 for uniform actions
    assert error < 0.01 * guessing_zero, (error, guessing_zero)
    assert float(model.last_loss) < 0.01 * guessing_zero


def test_the_standardiser_is_the_running_mean_and_spread_with_the_references_floor():
    data = torch.randn(5000, 3, generator=torch.Generator().manual_seed(1)) * torch.tensor([2.0, 0.5, 0.01]) + torch.tensor([1.0, -3.0, 7.0])
    standardize = RunningStandardizer(3, CPU)
    for chunk in data.split(100):
        standardize.update(chunk)
    standardized = standardize(data)
    assert standardized.mean(0).abs().max() < 1e-3
    assert standardized[:, :2].std(0).sub(1).abs().max() < 1e-3
    # a spread under √0.01 is divided by 0.1, not by itself: the third input keeps its small scale
    assert standardized[:, 2].std().item() == pytest.approx(data[:, 2].std().item() / np.sqrt(STD_FLOOR), rel=1e-3)


@pytest.fixture
def pendulum(store, cli):
    """Bundled demos, data set I (with the random policy's actions) and the identity embedding."""
    demos_and_identity(store, ENV, 1000)
    return cli


def _run(store, name, *settings):
    config = cfg.with_overrides(cfg.ImitationConfig(), ["method=bco", "train.steps=1000", "train.eval_every=1000",
                                                         "train.eval_episodes=3", "bco.interval=500", *settings])
    return imitate.imitate(store, env_id=ENV, demos_ref="ip", embedding_ref="ident", config=config, seed=0, name=name, device=CPU)


def test_cloning_the_inferred_actions_beats_the_untrained_policy(pendulum, store):
    """The same run with no gradient step of either network keeps the initial actor: the cloned one must balance
    the pole several times as long (a policy that learned nothing from the demo gets what the untrained one gets)."""
    untrained = _run(store, "untrained", "bco.pretrain_steps=0", "bco.idm_steps=0", "bco.bc_steps=0")
    cloned = _run(store, "cloned")
    assert cloned.metrics["return_mean"] > 3 * untrained.metrics["return_mean"], (cloned.metrics, untrained.metrics)
    curve = pd.read_csv(cloned.file(learning_curve.FILE))
    assert curve[learning_curve.IDM_LOSS].notna().all() and curve[learning_curve.BC_LOSS].notna().all()


def test_bco_imitates_end_to_end_from_the_cli_then_evaluates(pendulum, store):
    tiny = ("--steps", "400", "--eval-every", "200", "--set", "train.eval_episodes=1", "--set", "td3.hidden=16",
            "--set", "bco.interval=100", "--set", "bco.pretrain_steps=20", "--set", "bco.idm_hidden=16", "--set", "bco.lr=0.005")
    result = pendulum("imitate", ENV, "--demos", "ip", "--embedding", "ident", "--method", "bco", "--name", "b", *tiny)
    assert result.exit_code == 0, result.output
    assert "td3" not in result.output  # no warning about TD3's random steps: BCO runs none
    policy = store.resolve("b", "policy")
    assert policy.config["method"] == "bco" and policy.manifest["trained_on"] == METHODS["bco"].trained_on
    assert policy.config["bco"] == cfg.to_dict(cfg.with_overrides(cfg.ImitationConfig(method="bco"), ["bco.interval=100", "bco.pretrain_steps=20",
                                                                                      "bco.idm_hidden=16", "bco.lr=0.005"]))["bco"]
    assert policy.parent_kinds == ["demos", "embedding"] and policy.file("inverse_dynamics.safetensors").is_file()
    assert list(pd.read_csv(policy.file(learning_curve.FILE))["step"]) == [200, 400]
    evaluated = pendulum("eval", "b", "--episodes", "2")
    assert evaluated.exit_code == 0 and "return" in evaluated.output, evaluated.output
    drawn = pendulum("curve", "b")
    assert drawn.exit_code == 0 and "idm_loss" in drawn.output, drawn.output


def test_a_data_set_without_actions_or_a_disc_is_refused_in_one_line(store, cli, tmp_path):
    demos.import_bundled_demos(store, env_id=ENV, name="ip")
    states = write_states_npz(tmp_path / "states.npz", episodes=5, obs_dim=4)
    data = collect.import_dataset(store, env_id=ENV, name="stateonly", npz=states)
    embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, name="ident", device=CPU)
    refs = ("--demos", "ip", "--embedding", "ident", "--method", "bco", "--steps", "100")
    for args, message in [
        ((), f"--method bco learns from data set I's actions, but {data.ref} has none (imported state-only)"),
        (("--disc", "whatever"), "--method bco trains no warmed-up discriminator: drop --disc whatever"),
    ]:
        result = cli("imitate", ENV, *refs, *args)
        assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert not [kind for kind, *_ in committed_versions(store) if kind == "policy"]
    assert not store.runs._folder("policy", "invertedpendulum-v5-bco").exists()  # refused before the run was claimed
