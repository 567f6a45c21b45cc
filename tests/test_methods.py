"""The imitation methods' registry and its entries (methods/): each learner's reward checked by numbers, each entry
run end to end from the CLI, a new method's resume bit for bit, and the refusals of a wrong --method or --disc."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from conftest import committed_versions, demos_and_identity
from lwail_cli import config as cfg
from lwail_cli.discriminator import Critic
from lwail_cli.icvf import Encoder
from lwail_cli.methods import METHODS, Method
from lwail_cli.methods.gaifo import GaifoTrainer
from lwail_cli.methods.pwil import PrimalWassersteinReward
from lwail_cli.replay import ReplayBuffer
from lwail_cli.stages import collect, demos, embed, imitate
from lwail_cli.stages.chain import CHAIN, chain_for, reads
from lwail_cli.stages.sweep_plan import read_plan

ENV = "InvertedPendulum-v5"
CPU = torch.device("cpu")
TINY = ("--steps", "600", "--eval-every", "600", "--checkpoint-every", "600", "--set", "td3.hidden=16", "--set", "train.eval_episodes=1",
        "--set", "td3.random_steps=200", "--set", "td3.learning_starts=200", "--set", "td3.batch_size=32", "--set", "update_every=200",
        "--set", "update_steps=2")


def test_the_registry_lists_exactly_the_methods_the_config_offers():
    assert list(METHODS) == list(cfg.METHODS) == ["lwail", "gaifo", "pwil", "bco", "opolo", "difo"]
    assert all(method.name == name for name, method in METHODS.items())
    assert [name for name, method in METHODS.items() if method.reads_discriminator] == ["lwail"]
    # a reward learner for the TD3 loop, or a loop of its own: one of the two, never both
    assert [name for name, method in METHODS.items() if method.train is not None] == ["bco", "opolo"]
    assert all((method.build is None) != (method.train is None) for method in METHODS.values())
    assert [name for name, method in METHODS.items() if method.reads_actions] == ["bco", "opolo"]
    assert [name for name, method in METHODS.items() if not method.trains_td3] == ["bco"]
    # the methods whose records keep update_every and update_steps: those that train an adversary on that schedule
    assert cfg.ADVERSARIAL == tuple(name for name, method in METHODS.items() if method.caches_features)
    with pytest.raises(ValueError, match="one of them"):
        Method("both", "Both", "", reads_discriminator=False, caches_features=False, reward="", build=METHODS["gaifo"].build, train=METHODS["bco"].train)


def test_pwil_rewards_an_expert_atom_alpha_a_far_pair_nothing_and_spends_each_atom_once_per_episode():
    expert = torch.randn(10, 4, generator=torch.Generator().manual_seed(0), dtype=torch.float64).float()
    config = cfg.PwilConfig(time_horizon=10, subsampling=1)  # mass 1/10 per step: one atom's whole weight
    model = PrimalWassersteinReward(Encoder(2, None), expert, config)
    assert model.rewards(expert[:1], model._fresh())[0] == pytest.approx(config.alpha)  # exp(0)
    assert model.rewards(expert[:1] + 100.0, model._fresh())[0] < 1e-6
    # within one episode the atom is spent: the same pair again is coupled to another atom, farther away
    again = model.rewards(expert[[3, 3]], model._fresh())
    assert again[0] == pytest.approx(config.alpha) and again[1] < 0.5 * config.alpha
    # in the loop: the buffer's rewards as given, and the atoms restored when an episode ends
    buffer = ReplayBuffer(8, obs_dim=2, act_dim=1)
    pair = expert[3].numpy()  # identity φ: features [s, s' − s]
    for step in (1, 2):
        buffer.add(pair[:2], np.zeros(1), 0.0, pair[:2] + pair[2:], False)
        model.prepare(step, buffer)
    model.end_episode()
    buffer.add(pair[:2], np.zeros(1), 0.0, pair[:2] + pair[2:], False)
    model.prepare(3, buffer)
    rewards = buffer.storage["rewards"][:3, 0].numpy()
    assert rewards[0] == pytest.approx(config.alpha, rel=1e-5) and rewards[1] < 0.5 * config.alpha and rewards[2] == pytest.approx(rewards[0])


def test_gaifo_rewards_expert_pairs_above_policy_pairs_once_trained():
    torch.manual_seed(0)
    config = cfg.GaifoConfig(hidden=(16,), lr=1e-2)
    trainer = GaifoTrainer(Critic(2, config.hidden), config)
    expert, policy = torch.randn(256, 2) + 2.0, torch.randn(256, 2) - 2.0
    trainer.train(expert, policy, 1)
    untrained = trainer.estimate()["discriminator_loss"]
    trainer.train(expert, policy, 200)
    # −log(1 − D) is log 2 where D cannot tell a pair apart
    assert trainer.reward(expert).mean() > 1.0 > np.log(2.0) > 0.3 > trainer.reward(policy).mean() >= 0.0
    assert trainer.estimate()["discriminator_loss"] < 0.5 * untrained


@pytest.fixture
def pendulum(store, cli):
    """Bundled demos, a small random dataset and the identity embedding (no warm-up: the baselines read none)."""
    demos_and_identity(store, ENV, 300)
    return cli


OWN_SETTING = {"gaifo": "gaifo.lr=0.5", "pwil": "pwil.beta=0.5", "bco": "bco.lr=0.005", "opolo": "opolo.alpha=0.5", "difo": "difo.bce_weight=0.5"}  # one of each baseline's, recorded


@pytest.mark.parametrize("method", ["gaifo", "pwil", "bco", "opolo", "difo"])
def test_a_baseline_imitates_end_to_end_from_the_cli(pendulum, store, method):
    setting = OWN_SETTING[method]
    result = pendulum("imitate", ENV, "--demos", "ip", "--embedding", "ident", "--method", method, "--name", method, "--set", setting, *TINY)
    assert result.exit_code == 0, result.output
    policy = store.resolve(method, "policy")
    assert policy.config["method"] == method and policy.manifest["trained_on"] == METHODS[method].trained_on
    assert policy.config[method] == cfg.to_dict(cfg.with_overrides(cfg.ImitationConfig(method=method), [setting]))[method]
    reads_gaifo = {"gaifo"} if method == "opolo" else set()  # OPOLO's reward is GAIfO's D
    assert not {other for other in cfg.METHODS if other in policy.config} - {method} - reads_gaifo  # no other method's settings recorded
    assert policy.parent_kinds == ["demos", "embedding"]
    assert policy.file("discriminator.safetensors").is_file() == (method in ("gaifo", "opolo", "difo"))
    assert np.isfinite(policy.metrics["return_mean"])


def test_a_wrong_method_or_a_wrong_disc_is_refused_in_one_line(pendulum, store):
    refs = ("--demos", "ip", "--embedding", "ident")
    for args, message in [
        (("--method", "nosuch"), "method must be one of lwail, gaifo, pwil, bco, opolo, difo, got 'nosuch'"),
        (("--method", "gaifo", "--disc", "whatever"), "--method gaifo trains no warmed-up discriminator: drop --disc whatever"),
        (("--method", "lwail"), "--method lwail needs a warmed-up discriminator: give --disc REF"),
        ((), "--method lwail needs a warmed-up discriminator"),
    ]:
        result = pendulum("imitate", ENV, *refs, *args, *TINY)
        assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert not [kind for kind, *_ in committed_versions(store) if kind == "policy"]


class Killed(Exception):
    pass


@pytest.mark.parametrize("method", ["gaifo", "pwil", "bco", "opolo", "difo"])
def test_a_baseline_resumes_after_a_kill_bit_for_bit(store, method):
    bundled = demos.import_bundled_demos(store, env_id=ENV)
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=300), seed=0)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, device=CPU)
    config = cfg.ImitationConfig(
        method=method, td3=cfg.TD3Config(hidden=(32, 32), random_steps=300, learning_starts=300, batch_size=64),
        train=cfg.TrainConfig(steps=1500, eval_every=1500, eval_episodes=2, checkpoint_every=500), update_every=400, update_steps=3,
        bco=cfg.BcoConfig(idm_hidden=(32, 32), pretrain_steps=50, interval=300, idm_steps=20, bc_steps=20),
        opolo=cfg.OpoloConfig(idm_hidden=(32, 32), pretrain_steps=50, interval=300, idm_steps=20), difo=cfg.DifoConfig(hidden=(32, 32)),
    )
    stages = dict(env_id=ENV, demos_ref=bundled.ref, embedding_ref=embedding.ref, config=config, seed=0, device=CPU)
    straight = imitate.imitate(store, name="straight", **stages)

    def kill(step, shown):
        if step == 1000:
            raise Killed

    with pytest.raises(Killed):
        imitate.imitate(store, name="killed", on_progress=kill, **stages)
    assert store.runs.load_checkpoint("policy", "killed")["run"]["step"] == 500
    resumed = imitate.imitate(store, name="killed", resume=True, **stages)
    kept = {"gaifo": ("discriminator.safetensors",), "difo": ("discriminator.safetensors",), "bco": ("inverse_dynamics.safetensors",),
            "opolo": ("discriminator.safetensors", "inverse_dynamics.safetensors")}.get(method, ())
    for name in ("actor.safetensors",) + kept:
        assert straight.file(name).read_bytes() == resumed.file(name).read_bytes()
    pd.testing.assert_frame_equal(_curve(straight), _curve(resumed))  # the learner's diagnostics included


def _curve(policy):
    return pd.read_csv(policy.file("learning_curve.csv")).drop(columns="wall_time")


def test_a_plan_varies_methods_as_it_varies_embeddings_and_only_lwail_warms_up_a_discriminator():
    plan = read_plan(Path(__file__).parents[1] / "plans" / "methods-mujoco.toml")
    methods = {run.arm: (plan.embedding_kind(run.kind), plan.run_config("imitate", run).method) for run in plan.runs}
    assert methods == {f"{kind}-{method}": (kind, method) for kind in ("icvf", "identity") for method in cfg.METHODS}
    assert (len(plan.runs), len(plan.phis)) == (36, 6)
    names = {run.method: plan.names(run) for run in plan.runs if (run.task, run.kind) == ("Hopper-v5", "icvf")}
    assert {n["embedding"] for n in names.values()} == {"methods-mujoco-hopper-v5-s0-icvf"}  # one φ for the six methods
    assert [n["policy"] for n in names.values()] == [f"methods-mujoco-hopper-v5-s0-icvf-{m}" for m in cfg.METHODS]
    assert chain_for("lwail") == CHAIN and chain_for("gaifo") == chain_for("pwil") == ("collect", "pretrain-icvf", "imitate")
    assert reads("imitate", "lwail") == ("demos", "embedding", "discriminator") and reads("imitate", "pwil") == ("demos", "embedding")
