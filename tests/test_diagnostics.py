"""What explains a run: critic diagnostics at every evaluation, a live curve, and the embedding's critic probe."""

import numpy as np
import pandas as pd
import pytest
import torch
from safetensors.torch import load_file

from lwail_cli import config as cfg
from lwail_cli import learning_curve
from lwail_cli.data import Episode
from lwail_cli.discriminator import Critic, DiscriminatorTrainer
from lwail_cli.nets import Encoder
from lwail_cli.probes import probe_critic_needs
from lwail_cli.data import transition_pairs
from lwail_cli.imitation import AdversarialReward
from lwail_cli.loaders import load_critic, load_dataset, load_encoder, parent
from lwail_cli.stages.shared import pair_features
from lwail_cli.rollout import Rollouts
from lwail_cli.stages import collect, demos, embed, imitate, warmup

ENV = "InvertedPendulum-v5"


def test_diagnostics_of_a_constant_critic_are_known():
    critic = Critic(4, hidden=())
    with torch.no_grad():
        critic.net[0].weight.zero_()
        critic.net[0].bias.fill_(1.0)  # f ≡ 1: every pair is rewarded σ(−1)
    trainer = DiscriminatorTrainer(critic, cfg.CriticConfig(hidden=()))
    model = AdversarialReward(Encoder(2, None), trainer, torch.randn(10, 4), 8, update_every=4, update_steps=1, random_features=torch.randn(6, 4))
    lengths = [3, 7, 5]  # pseudo-return = σ(−1)·length, so it ranks episodes as returns 1, 3, 2 do
    episodes = [Episode(observations=np.random.default_rng(n).normal(size=(n + 1, 2)).astype(np.float32)) for n in lengths]
    row = model.metrics(Rollouts(returns=np.array([1.0, 3.0, 2.0]), episodes=episodes))
    expected = 1 / (1 + np.e)
    assert row["reward_expert_mean"] == pytest.approx(expected) and row["reward_random_mean"] == pytest.approx(expected)
    assert row["pseudo_return_spearman"] == pytest.approx(1.0)
    shuffled = model.metrics(Rollouts(returns=np.array([2.0, 1.0, 3.0]), episodes=episodes))
    assert shuffled["pseudo_return_spearman"] == pytest.approx(-0.5)  # ranks (1, 3, 2) vs (2, 1, 3)


def test_critic_probe_sees_progress_and_separation_in_raw_states():
    rng = np.random.default_rng(0)
    expert = [Episode(observations=np.stack([np.linspace(0, 10, 101), rng.normal(0, 0.01, 101)], 1).astype(np.float32)) for _ in range(3)]
    random = [Episode(observations=rng.normal(0, 1, (30, 2)).astype(np.float32)) for _ in range(10)]
    found = probe_critic_needs(lambda x: x, expert, random)
    assert found["separation_auc"] == pytest.approx(1.0) and found["progress_spearman"] == pytest.approx(1.0)
    backwards = [Episode(observations=e.observations[::-1].copy()) for e in expert]
    assert probe_critic_needs(lambda x: x, backwards, random)["progress_spearman"] == pytest.approx(1.0)
    assert np.isnan(probe_critic_needs(lambda x: x, expert[:1], random)["separation_auc"])  # needs a second trajectory


class Killed(Exception):
    pass


@pytest.fixture
def stages(store):
    device = torch.device("cpu")
    bundled = demos.import_bundled_demos(store, env_id=ENV)
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=600), seed=0)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, device=device, demos_ref=bundled.ref)
    return store, device, bundled, embedding


def test_the_curve_and_its_diagnostics_are_readable_while_a_run_goes_and_after(stages, cli):
    store, device, bundled, embedding = stages
    assert 0.0 <= embedding.metrics["probe_separation_auc"] <= 1.0 and "probe_progress_spearman_raw" in embedding.metrics
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=bundled.ref, config=cfg.WarmupConfig(steps=5), seed=0, device=device)
    config = cfg.ImitationConfig(
        td3=cfg.TD3Config(hidden=(32, 32), random_steps=300, learning_starts=300, batch_size=64),
        train=cfg.TrainConfig(steps=1500, eval_every=500, eval_episodes=2, checkpoint_every=500),
        update_every=400, update_steps=2,
    )
    run = dict(env_id=ENV, demos_ref=bundled.ref, embedding_ref=embedding.ref, disc_ref=disc.ref, config=config, seed=0, device=device, name="run")

    def kill(step, shown):  # after the evaluation at 1000 is logged, before its checkpoint: resumes from 500
        if step == 1000:
            raise Killed

    with pytest.raises(Killed):
        imitate.imitate(store, on_progress=kill, **run)
    result = cli("curve", "run", "--out", store.root / "live.png")
    assert result.exit_code == 0, result.output
    assert "in progress or killed" in result.output and (store.root / "live.png").stat().st_size > 0
    # without --out, beside the killed run's curve in the run area
    assert cli("curve", "run").output.splitlines()[-1] == f"wrote {store.runs.run_log('policy', 'run', 'curve.png')}"
    lines = [line.split() for line in result.output.splitlines()]
    assert [row[0] for row in lines if row and row[0].isdigit()] == ["500", "1000"]
    header = next(row for row in lines if row and row[0] == "step")
    for column in ("reward_expert_mean", "pseudo_reward_mean", "reward_random_mean", "wasserstein_estimate", "pseudo_return_spearman",
                   "pseudo_reward_std", "reward_slope_policy", "critic_shift", "actor_normalized_score"):
        assert column in header
    live = pd.read_csv(store.runs.run_log("policy", "run", "learning_curve.csv"))
    kept, other = live.loc[live["step"] == 1000, ["normalized_score", "actor_normalized_score"]].iloc[0]
    # over the 1000 steps so far, the second half holds only the evaluation at 1000: last = its mean = its lowest
    assert f"kept network, normalized_score over 1000 steps: last {kept:.1f} · best {live['normalized_score'].max():.1f}" in result.output
    assert f"after half the steps: mean {kept:.1f}, lowest {kept:.1f} (step 1000)" in result.output
    assert f"actor network (not kept), actor_normalized_score over 1000 steps: last {other:.1f}" in result.output

    finished = imitate.imitate(store, resume=True, **run)
    curve = pd.read_csv(finished.file("learning_curve.csv"))
    assert list(curve["step"]) == [500, 1000, 1500]
    assert curve[["reward_expert_mean", "reward_random_mean"]].notna().all().all()
    assert finished.config["critic"]["tanh"] is True  # inherited from the warm-up (default: tanh)
    assert cli("curve", "run", "--out", store.root / "done.png").output.startswith("policy/run@v1")
    assert cli("curve", "run").output.splitlines()[-1] == f"wrote {finished.path / 'curve.png'}"  # then beside the policy
    beside = cli("curve", "run", "policy/run@v1", "--out", store.root / "both.png")  # one panel per run
    assert beside.exit_code == 0 and beside.output.count("policy/run@v1: ") == 2 and (store.root / "both.png").stat().st_size > 0


def test_imitate_keeps_the_loss_form_the_critic_was_warmed_up_with(stages, cli):
    store, device, bundled, embedding = stages
    assert cli("warmup-disc", embedding.ref, bundled.ref, "--set", "steps=2", "--set", "critic.tanh=false", "--name", "plain").exit_code == 0
    result = cli("imitate", ENV, "--demos", bundled.ref, "--embedding", embedding.ref, "--disc", "plain", "--steps", "300",
                 "--set", "td3.random_steps=100", "--set", "td3.learning_starts=300", "--eval-every", "300", "--set", "train.eval_episodes=1")
    assert result.exit_code == 0, result.output
    assert store.resolve("invertedpendulum-v5-lwail", "policy").config["critic"]["tanh"] is False


def test_a_standardized_critic_is_fitted_on_data_set_i_saved_and_inherited_by_imitate(stages, cli):
    store, device, bundled, embedding = stages
    assert cli("warmup-disc", embedding.ref, bundled.ref, "--set", "steps=2", "--set", "critic.standardize=true", "--name", "scaled").exit_code == 0
    disc = store.resolve("scaled", "discriminator")
    critic = load_critic(disc)
    features = pair_features(load_encoder(embedding, device), *transition_pairs(load_dataset(parent(store, disc, "dataset"))), device)
    assert torch.allclose(critic.standardized(features).mean(0), torch.zeros(8), atol=1e-4)  # the saved statistics are data set I's
    result = cli("imitate", ENV, "--demos", bundled.ref, "--embedding", embedding.ref, "--disc", "scaled", "--steps", "300",
                 "--set", "td3.random_steps=100", "--set", "td3.learning_starts=300", "--eval-every", "300", "--set", "train.eval_episodes=1")
    assert result.exit_code == 0, result.output
    policy = store.resolve("invertedpendulum-v5-lwail", "policy")
    assert policy.config["critic"]["standardize"] is True
    assert torch.equal(load_file(policy.file("critic.safetensors"))["scale"], critic.scale)  # f's online updates kept its units


def test_pretraining_with_demos_logs_the_critic_probe_at_every_log_step(store):
    bundled = demos.import_bundled_demos(store, env_id=ENV)
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=600), seed=0)
    config = cfg.EmbedConfig(icvf=cfg.ICVFConfig(steps=30, batch_size=32, hidden=(16,), embedding_dim=8, log_every=10))
    embedding = embed.embed(store, data_ref=data.ref, config=config, seed=0, device=torch.device("cpu"), demos_ref=bundled.ref)
    log = pd.read_csv(embedding.file("loss.csv"))
    assert log["step"].tolist() == [10, 20, 30]
    assert log[["separation_auc", "progress_spearman"]].notna().all().all()
    assert log["separation_auc"].between(0.0, 1.0).all()
    final = log.iloc[-1]  # the last row probes the φ that was saved
    assert final["separation_auc"] == pytest.approx(embedding.metrics["probe_separation_auc"])
    assert final["progress_spearman"] == pytest.approx(embedding.metrics["probe_progress_spearman"])


def test_imitate_writes_the_target_actor_by_default(stages):
    """Killed after its 500-step checkpoint and ended there (--steps 500): the artifact's actor is the checkpoint's target actor."""
    store, device, bundled, embedding = stages
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=bundled.ref, config=cfg.WarmupConfig(steps=5), seed=0, device=device)
    td3 = cfg.TD3Config(hidden=(32, 32), random_steps=300, learning_starts=300, batch_size=64)
    run = dict(env_id=ENV, demos_ref=bundled.ref, embedding_ref=embedding.ref, disc_ref=disc.ref, seed=0, device=device, name="run")

    def config(steps):
        train = cfg.TrainConfig(steps=steps, eval_every=500, eval_episodes=2, checkpoint_every=500)  # policy: target by default
        return cfg.ImitationConfig(td3=td3, train=train, update_every=400, update_steps=2)

    def kill(step, shown):  # progress is reported every 500 steps: the last report, before the artifact is written
        if step == 1000:
            raise Killed

    with pytest.raises(Killed):
        imitate.imitate(store, config=config(1000), on_progress=kill, **run)
    agent = store.runs.load_checkpoint("policy", "run")["agent"]
    finished = imitate.imitate(store, config=config(500), resume=True, **run)
    from safetensors.torch import load_file

    written = load_file(finished.file("actor.safetensors"))
    assert all(torch.equal(written[k], agent["actor_target"][k]) for k in written)
    assert not torch.equal(written["net.0.weight"], agent["actor"]["net.0.weight"])
    curve = pd.read_csv(finished.file("learning_curve.csv"))
    assert curve[["normalized_score", "actor_normalized_score"]].notna().all().all()


@pytest.mark.parametrize("steps, wasserstein, warned", [
    ((100_000, 150_000, 160_000), (1.99, 1.97, 1.80), True),  # judged at the first evaluation from 150k on
    ((100_000, 150_000, 160_000), (1.99, 1.90, 1.99), False),
    ((50_000, 100_000), (1.99, 1.99), False),  # too early to tell
])
def test_a_critic_still_saturated_at_150k_steps_is_flagged(steps, wasserstein, warned):
    curve = pd.DataFrame({"step": steps, "wasserstein_estimate": wasserstein, "reward_expert_mean": 0.99, "pseudo_reward_mean": 0.01})
    note = learning_curve.saturated_critic(curve)
    assert (note is not None) == warned
    if warned:
        assert note.startswith("warning: f is saturated at step 150000 (Wasserstein estimate 1.970")
    assert learning_curve.saturated_critic(curve.drop(columns="wasserstein_estimate")) is None  # an expert's curve


def test_a_running_imitation_warns_once_at_the_evaluation_that_finds_f_saturated():
    from lwail_cli.stages.online import WARNING, run_summary
    from lwail_cli.training import RunState

    row = {"return_mean": 1.0, "wasserstein_estimate": 1.99, "reward_expert_mean": 0.99, "pseudo_reward_mean": 0.01}
    history = [{"step": 140_000, **row}, {"step": 150_000, **row}]
    assert WARNING in run_summary(RunState(step=150_000, history=history))
    assert WARNING not in run_summary(RunState(step=150_100, history=history))  # progress between evaluations
    assert WARNING not in run_summary(RunState(step=160_000, history=history + [{"step": 160_000, **row}]))  # said once
    plain_dual = [{"step": 100_000, **row, "wasserstein_estimate": 3.5}, {"step": 150_000, **row}]
    assert learning_curve.saturated_critic(pd.DataFrame(plain_dual)) is None  # no tanh ceiling to be near


def test_the_curve_summary_ends_with_the_saturation_warning():
    from lwail_cli.stages.curve import summary_lines

    curve = pd.DataFrame({"step": [100_000, 150_000], "return_mean": 1.0, "normalized_score": [0.5, 0.7], "wasserstein_estimate": 1.99,
                          "reward_expert_mean": 0.99, "pseudo_reward_mean": 0.01})
    assert summary_lines(curve)[-1].startswith("warning: f is saturated at step 150000")
    assert not summary_lines(curve.assign(wasserstein_estimate=1.5))[-1].startswith("warning")
