import numpy as np
import pandas as pd
import pytest
import torch

from lwail_cli import config as cfg
from lwail_cli.stages import collect, demos, embed, evaluate, expert, imitate, warmup
from lwail_cli.loaders import load_policy
from lwail_cli.data import Episode
from lwail_cli.errors import LwailError
from lwail_cli.discriminator import Critic, DiscriminatorTrainer, critic_loss, gradient_penalty, transition_features
from lwail_cli.icvf import GoalSampler, pretrain_icvf
from lwail_cli.nets import Encoder
from lwail_cli.imitation import AdversarialReward
from lwail_cli.replay import ReplayBuffer


def chain_episodes(seed=0, cells=100, code_dim=16, episodes=60, length=40):
    """A chain walked mostly rightwards, observed through a random code per cell: raw distances
    between codes say nothing about how many steps apart two states are."""
    rng = np.random.default_rng(seed)
    codes = rng.normal(size=(cells, code_dim)).astype(np.float32)
    result = []
    for _ in range(episodes):
        position, positions = int(rng.integers(0, cells // 3)), []
        for _ in range(length + 1):
            positions.append(position)
            position = int(np.clip(position + (1 if rng.random() < 0.85 else -1), 0, cells - 1))
        result.append(Episode(observations=codes[positions]))
    return result


@pytest.mark.parametrize("layer_norm", ["none", "after", "before"])
def test_icvf_latent_distance_tracks_time_better_than_raw_states(layer_norm):
    # (ICVF's TD loss rises while values grow from 0 towards their fixed point, so the probe is the check.)
    # lr 1e-2: at 1e-3, φ without LayerNorm learns this chain far more slowly (probe 0.035 after 1,500 steps, 0.165 with it)
    config = cfg.ICVFConfig(steps=1500, hidden=(32,), embedding_dim=32, log_every=500, lr=1e-2, gamma=0.9, layer_norm=layer_norm)
    result = pretrain_icvf(chain_episodes(), obs_dim=16, config=config, seed=0)
    assert abs(result.probe_raw) < 0.05  # random codes: raw distance says ~nothing about time apart
    assert result.probe_latent > result.probe_raw + 0.08, (result.probe_latent, result.probe_raw)
    assert result.log["probe_latent"].iloc[-1] > result.log["probe_latent"].iloc[0]


def test_how_often_icvf_logs_does_not_change_the_trained_embedding():
    runs = [pretrain_icvf(chain_episodes(episodes=6, length=20), obs_dim=16,
                          config=cfg.ICVFConfig(steps=40, batch_size=32, hidden=(16,), embedding_dim=8, log_every=every), seed=0)
            for every in (5, 40)]
    assert [len(run.log) for run in runs] == [8, 1]
    for name, tensor in runs[0].encoder.state_dict().items():
        assert torch.equal(tensor, runs[1].encoder.state_dict()[name]), name


def test_goal_sampler_respects_trajectories_and_rewards():
    episodes = chain_episodes(episodes=5, length=10)
    sampler = GoalSampler(episodes, cfg.ICVFConfig(p_goal_current=0.0, p_goal_trajectory=1.0), torch.device("cpu"))
    batch = sampler.sample(512)
    assert torch.all(batch["intention_reward"] == -1) and torch.all(batch["intention_mask"] == 1)  # later states only
    current = GoalSampler(episodes, cfg.ICVFConfig(p_goal_current=1.0, p_goal_trajectory=0.0), torch.device("cpu")).sample(64)
    assert torch.all(current["intention_reward"] == 0) and torch.all(current["intention_mask"] == 0)
    assert torch.equal(current["intention"], current["s"])
    # observations (episode, time) name their row: a trajectory goal is a later state of s's own episode
    labelled = [Episode(observations=np.stack([np.full(n + 1, e), np.arange(n + 1)], axis=1).astype(np.float32))
                for e, n in enumerate((3, 7, 12))]
    torch.manual_seed(0)
    batch = GoalSampler(labelled, cfg.ICVFConfig(p_goal_current=0.0, p_goal_trajectory=1.0), torch.device("cpu")).sample(512)
    s, next_s, intention = batch["s"], batch["next_s"], batch["intention"]
    assert torch.equal(next_s, s + torch.tensor([0.0, 1.0]))  # s' is the next state of the same episode
    assert torch.equal(intention[:, 0], s[:, 0]) and torch.all(intention[:, 1] > s[:, 1])
    lengths = torch.tensor([3.0, 7.0, 12.0])[s[:, 0].long()]
    assert torch.all(s[:, 1] < lengths) and torch.all(intention[:, 1] <= lengths)  # never past the episode's last state
    assert set(s[:, 0].tolist()) == {0.0, 1.0, 2.0} and torch.any(intention[:, 1] > s[:, 1] + 1)  # goals beyond s'


def test_gradient_penalty_of_a_linear_critic_is_known():
    critic = Critic(3, hidden=())  # f(x) = w·x + b: its gradient is w everywhere
    with torch.no_grad():
        critic.net[0].weight.copy_(torch.tensor([[2.0, 1.0, 2.0]]))  # ‖w‖ = 3
    expert, policy = torch.randn(100, 3), torch.randn(100, 3)
    assert gradient_penalty(critic, expert, policy).item() == pytest.approx((3.0 - 1.0) ** 2)
    with torch.no_grad():
        critic.net[0].weight.copy_(torch.tensor([[0.6, 0.8, 0.0]]))  # ‖w‖ = 1: no penalty
    assert gradient_penalty(critic, expert, policy).item() == pytest.approx(0.0, abs=1e-10)


def test_a_standardized_critic_penalises_its_slope_in_standardized_units():
    rng = np.random.default_rng(0)
    features = torch.as_tensor(np.stack([rng.normal(5.0, 10.0, 4000), rng.normal(-1.0, 0.1, 4000), np.full(4000, 3.0)], 1), dtype=torch.float32)
    critic = Critic(3, hidden=(), standardize=True)
    critic.fit_standardization(features)
    z = critic.standardized(features)
    assert torch.allclose(z[:, :2].mean(0), torch.zeros(2), atol=1e-4) and torch.allclose(z[:, :2].std(0), torch.ones(2), atol=1e-4)
    assert torch.equal(z[:, 2], torch.zeros(4000))  # an input that never varies is centred, not blown up
    with torch.no_grad():
        critic.net[0].weight.copy_(torch.tensor([[0.6, 0.8, 0.0]]))  # slope 1 in standardized units, 0.08 and 8 in raw ones
    expert, policy = features[:2000], features[2000:]
    loss, wasserstein = critic_loss(critic, expert, policy, cfg.CriticConfig(hidden=(), tanh=False, gp_weight=10.0))
    assert loss.item() == pytest.approx(-wasserstein.item(), abs=1e-5)  # no penalty
    raw_slope = (critic.net[0].weight[0, :2] / critic.scale[:2]).norm().item()  # ≈ ‖(0.06, 8)‖
    assert gradient_penalty(critic, expert, policy).item() == pytest.approx((raw_slope - 1.0) ** 2, rel=1e-4)  # in raw units there would be


@pytest.mark.parametrize("tanh, wasserstein_at_least", [(False, 3.0), (True, 1.5)])
def test_critic_learns_to_separate_expert_from_policy(tanh, wasserstein_at_least):
    config = cfg.CriticConfig(hidden=(16, 16), tanh=tanh)
    torch.manual_seed(0)
    trainer = DiscriminatorTrainer(Critic(2, config.hidden), config)
    expert, policy = torch.randn(256, 2) + 2.0, torch.randn(256, 2) - 2.0
    trainer.train(expert, policy, 200)
    assert trainer.reward(expert).mean() > 0.85 > 0.15 > trainer.reward(policy).mean()
    # the means are ‖(4, 4)‖ ≈ 5.7 apart; with tanh the estimate is of tanh f, so at most 2
    assert trainer.last_wasserstein > wasserstein_at_least


def test_relabelling_makes_every_reward_sigma_of_minus_current_f():
    torch.manual_seed(0)
    config = cfg.CriticConfig(hidden=(8,))
    encoder = Encoder(3, None)
    trainer = DiscriminatorTrainer(Critic(6, config.hidden), config)
    expert = torch.randn(40, 6)
    model = AdversarialReward(encoder, trainer, expert, capacity=80, update_every=50, update_steps=3)
    buffer = ReplayBuffer(80, obs_dim=3, act_dim=1)
    rng = np.random.default_rng(0)
    weights_before = trainer.critic.net[0].weight.clone()
    for step in range(1, 121):  # wraps the buffer and crosses two f updates
        buffer.add(rng.normal(size=3), rng.normal(size=1), 123.0, rng.normal(size=3), False)
        model.prepare(step, buffer)
    assert not torch.equal(weights_before, trainer.critic.net[0].weight)
    storage = buffer.storage
    with torch.no_grad():
        expected = torch.sigmoid(-trainer.critic(transition_features(encoder, storage["observations"], storage["next_observations"])))
    assert torch.allclose(storage["rewards"][:, 0], expected, atol=1e-6)
    recent = torch.arange(50, 100) % 80  # the pairs of the last update of f (at step 100), not overwritten since
    assert model.recent["pseudo_reward_std"].item() == pytest.approx(expected[recent].std().item(), rel=1e-5)
    assert model.recent["critic_shift"].item() > 0.0  # f moved at its last update


def test_reward_slope_of_a_linear_critic_is_known_and_a_frozen_critic_does_not_move():
    critic = Critic(4, hidden=())  # f(x) = w·[s, s' − s] + b, so ∂f/∂s' = w's second half
    with torch.no_grad():
        critic.net[0].weight.copy_(torch.tensor([[1.0, -2.0, 3.0, 4.0]]))
    trainer = DiscriminatorTrainer(critic, cfg.CriticConfig(hidden=()))
    model = AdversarialReward(Encoder(2, None), trainer, torch.randn(10, 4), capacity=40, update_every=20, update_steps=0)
    buffer = ReplayBuffer(40, obs_dim=2, act_dim=1)
    rng = np.random.default_rng(1)
    for step in range(1, 21):
        buffer.add(rng.normal(size=2), rng.normal(size=1), 0.0, rng.normal(size=2), False)
        model.prepare(step, buffer)
    reward = buffer.storage["rewards"][:20, 0]
    expected = (reward * (1 - reward)).mean() * 5.0  # |∂σ(−f)/∂f| · ‖(3, 4)‖
    assert model.recent["reward_slope_policy"].item() == pytest.approx(expected.item(), rel=1e-5)
    assert model.recent["critic_shift"].item() == 0.0  # no update steps: f did not move


def _expert_config(steps, checkpoint_every):
    td3 = cfg.TD3Config(hidden=(32, 32), random_steps=300, learning_starts=300, batch_size=64)
    return cfg.ExpertConfig(td3=td3, train=cfg.TrainConfig(steps=steps, eval_every=steps, eval_episodes=2, checkpoint_every=checkpoint_every))


class Killed(Exception):
    pass


def test_resume_after_a_kill_continues_exactly_from_the_checkpoint(store):
    device = torch.device("cpu")
    config = _expert_config(1200, 500)
    straight = expert.train_expert(store, env_id="Hopper-v5", config=config, seed=3, name="straight", device=device)

    def kill_after_checkpoint(step, shown):
        if step == 1000:  # before the checkpoint at 1000 is written: steps 501-1000 are lost and redone
            raise Killed

    with pytest.raises(Killed):
        expert.train_expert(store, env_id="Hopper-v5", config=config, seed=3, name="killed", device=device, on_progress=kill_after_checkpoint)
    checkpoint = store.runs.load_checkpoint("policy", "killed")
    assert checkpoint["run"]["step"] == 500
    # the layout lwail has always written: a run killed under an older lwail resumes under this one
    assert set(checkpoint) == {"agent", "buffer", "reward_model", "run", "noise_rng", "torch_rng", "cuda_rng", "env", "obs", "record"}
    resumed = expert.train_expert(store, env_id="Hopper-v5", config=config, seed=3, name="killed", device=device, resume=True)
    a = load_policy(straight).state_dict()
    b = load_policy(resumed).state_dict()
    assert all(torch.equal(a[key], b[key]) for key in a)
    assert straight.metrics["return_mean"] == resumed.metrics["return_mean"]


def _pendulum_chain(store, transitions, icvf, warmup_steps):
    """Bundled InvertedPendulum demos, random data, an ICVF embedding and a warmed-up discriminator (seed 0, CPU)."""
    bundled = demos.import_bundled_demos(store, env_id="InvertedPendulum-v5")
    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=transitions), seed=0)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=torch.device("cpu"))
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=bundled.ref, config=cfg.WarmupConfig(steps=warmup_steps),
                         seed=0, device=torch.device("cpu"))
    return bundled, data, embedding, disc


@pytest.mark.slow
def test_lwail_imitates_inverted_pendulum_from_one_state_only_trajectory(store):
    device = torch.device("cpu")
    bundled, data, embedding, disc = _pendulum_chain(store, 3000, cfg.ICVFConfig(steps=300, hidden=(64,), embedding_dim=64, log_every=300), 200)
    assert disc.metrics["reward_expert_mean"] > disc.metrics["reward_random_mean"]
    config = cfg.ImitationConfig(
        td3=cfg.TD3Config(random_steps=2000, learning_starts=2000),
        # TD3 on InvertedPendulum sits at returns ~50-100 before it jumps to 1000 (here at ~18k steps)
        train=cfg.TrainConfig(steps=24_000, eval_every=6_000, eval_episodes=5, checkpoint_every=24_000),
        update_every=2000,
    )
    policy = imitate.imitate(store, env_id="InvertedPendulum-v5", demos_ref=bundled.ref, embedding_ref=embedding.ref, disc_ref=disc.ref,
                             config=config, seed=0, device=device)
    assert policy.metrics["normalized_score"] > 80, policy.metrics
    for artifact_file in ("actor.safetensors", "learning_curve.csv", "learning_curve.png", "pseudo_reward_vs_return.png"):
        assert policy.file(artifact_file).is_file()
    result = evaluate.evaluate(store, policy_ref=policy.ref, config=cfg.EvalConfig(episodes=5), normalized=True)
    assert result["normalized_score"] > 80 and "bundled-demos" in result["reference"]


def _imitation_stages(store) -> dict:
    """A tiny LWAIL imitation on InvertedPendulum (identity φ): 1,500 steps, checkpoints every 500."""
    device = torch.device("cpu")
    bundled = demos.import_bundled_demos(store, env_id="InvertedPendulum-v5")
    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=500), seed=0)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, device=device)
    warm = cfg.WarmupConfig(critic=cfg.CriticConfig(hidden=(16, 16)), steps=5)
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=bundled.ref, config=warm, seed=0, device=device)
    config = cfg.ImitationConfig(
        td3=cfg.TD3Config(hidden=(32, 32), random_steps=300, learning_starts=300, batch_size=64),
        train=cfg.TrainConfig(steps=1500, eval_every=1500, eval_episodes=2, checkpoint_every=500),
        update_every=400,
        update_steps=3,
    )
    return dict(env_id="InvertedPendulum-v5", demos_ref=bundled.ref, embedding_ref=embedding.ref, disc_ref=disc.ref, config=config, seed=0, device=device)


def _imitations_killed_at_1000(store, stages: dict, *names: str) -> None:
    """Start an imitation of each name and kill it at step 1000 (its checkpoint at 500 survives)."""
    def kill(step, shown):
        if step == 1000:
            raise Killed

    for name in names:
        with pytest.raises(Killed):
            imitate.imitate(store, name=name, on_progress=kill, **stages)


def test_imitation_resume_after_a_kill_matches_an_uninterrupted_run(store):
    stages = _imitation_stages(store)
    config = stages["config"]
    straight = imitate.imitate(store, name="straight", **stages)
    _imitations_killed_at_1000(store, stages, "killed", "observed")
    resumed = imitate.imitate(store, name="killed", resume=True, **stages)
    # evaluating 4x as often (the critic's diagnostics included) and checkpointing elsewhere changes nothing trained
    observed_config = cfg.with_overrides(config, ["train.eval_every=250", "train.eval_episodes=1", "train.checkpoint_every=700"])
    observed = imitate.imitate(store, name="observed", resume=True, **{**stages, "config": observed_config})
    assert pd.read_csv(observed.file("learning_curve.csv"))["step"].tolist() == [750, 1000, 1250, 1500]
    for name in ("actor.safetensors", "critic.safetensors"):
        assert straight.file(name).read_bytes() == resumed.file(name).read_bytes() == observed.file(name).read_bytes()


def test_a_checkpoint_lwail_0_3_wrote_resumes_bit_for_bit_and_one_of_another_run_is_still_refused(store):
    """lwail 0.3 recorded every section of a run's config, read or not (gaifo.*, pwil.* in an LWAIL run): its checkpoint
    is the same run and resumes; one whose recorded config differs in what the run reads is refused as before."""
    stages = _imitation_stages(store)
    straight = imitate.imitate(store, name="straight", **stages)
    _imitations_killed_at_1000(store, stages, "from-0.3", "other-0.3")
    as_0_3 = cfg.recorded_by_0_3(stages["config"])
    assert {"gaifo", "pwil"} <= set(as_0_3) and "bco" not in as_0_3 and "gaifo" not in cfg.to_dict(stages["config"])
    for name, config in (("from-0.3", as_0_3), ("other-0.3", {**as_0_3, "update_steps": 4})):
        state = store.runs.load_checkpoint("policy", name)
        state["record"]["config"] = config | {"critic": state["record"]["config"]["critic"]}
        store.runs.save_checkpoint("policy", name, state)
    resumed = imitate.imitate(store, name="from-0.3", resume=True, **stages)
    for name in ("actor.safetensors", "critic.safetensors"):
        assert straight.file(name).read_bytes() == resumed.file(name).read_bytes()
    with pytest.raises(LwailError, match="made with another config"):
        imitate.imitate(store, name="other-0.3", resume=True, **stages)


@pytest.mark.parametrize("ask", ["lwail pause", "SIGTERM"])
def test_a_run_asked_to_pause_checkpoints_there_and_resumes_bit_for_bit(store, ask):
    import os
    import signal

    from lwail_cli.errors import RunPaused

    stages = _imitation_stages(store)
    straight = imitate.imitate(store, name="straight", **stages)

    def pause_at_600(step, shown):
        if step == 600:  # between two checkpoints (every 500): what a kill would lose, a pause keeps
            store.runs.request_pause("paused") if ask == "lwail pause" else os.kill(os.getpid(), signal.SIGTERM)

    handler = signal.getsignal(signal.SIGTERM)
    with pytest.raises(RunPaused, match="paused at step 600 as asked, its checkpoint kept"):
        imitate.imitate(store, name="paused", on_progress=pause_at_600, **stages)
    assert signal.getsignal(signal.SIGTERM) is handler  # the run's own handler is gone with it
    assert store.runs.load_checkpoint("policy", "paused")["run"]["step"] == 600
    resumed = imitate.imitate(store, name="paused", resume=True, **stages)  # the request was taken: it runs to the end
    for name in ("actor.safetensors", "critic.safetensors"):
        assert straight.file(name).read_bytes() == resumed.file(name).read_bytes()
    pd.testing.assert_frame_equal(*(pd.read_csv(p.file("learning_curve.csv")).drop(columns="wall_time") for p in (straight, resumed)))


def test_a_pause_says_the_same_after_the_trip_a_sweep_gives_it():
    """Ray hands a run's error back to the sweep pickled: the line the user reads must survive it."""
    import pickle

    from lwail_cli.errors import RunPaused

    paused = pickle.loads(pickle.dumps(RunPaused(451_300)))
    assert str(paused) == str(RunPaused(451_300)) and str(paused).startswith("paused at step 451300 as asked") and paused.step == 451_300


def test_a_pause_asked_of_a_process_that_was_then_killed_does_not_stop_its_resumed_run(store, cli):
    stages = _imitation_stages(store)

    def ask_then_die(step, shown):
        if step == 600:
            store.runs.request_pause("run")
            raise Killed  # before the loop looks at the request

    with pytest.raises(Killed):
        imitate.imitate(store, name="run", on_progress=ask_then_die, **stages)
    assert imitate.imitate(store, name="run", resume=True, **stages).metrics["env_steps"] == 1500
    result = cli("pause", "run")  # finished: nothing to pause
    assert result.exit_code == 1 and "no run named run is in progress in this store" in result.output and "Traceback" not in result.output


def test_resume_refuses_a_run_started_differently(store):
    config = _expert_config(1200, 500)

    def kill(step, shown):
        if step == 1000:
            raise Killed

    with pytest.raises(Killed):
        expert.train_expert(store, env_id="InvertedPendulum-v5", config=config, seed=3, name="run", device=torch.device("cpu"), on_progress=kill)
    with pytest.raises(LwailError, match="made with another seed"):
        expert.train_expert(store, env_id="InvertedPendulum-v5", config=config, seed=4, name="run", device=torch.device("cpu"), resume=True)
    with pytest.raises(LwailError, match="made with another env"):
        expert.train_expert(store, env_id="InvertedDoublePendulum-v5", config=config, seed=3, name="run", device=torch.device("cpu"), resume=True)


def test_resume_may_change_the_budget_and_schedule_but_not_what_trains(store):
    """--resume --steps N: a longer run matches one that had N from the start; N = the checkpoint's step stops there.
    Anything that trains differently (here TD3's batch, or which network is kept) is refused."""
    device = torch.device("cpu")
    td3 = _expert_config(1200, 500).td3

    def budget(steps):
        return cfg.ExpertConfig(td3=td3, train=cfg.TrainConfig(steps=steps, eval_every=1200, eval_episodes=2, checkpoint_every=500))

    def kill(step, shown):
        if step == 1000:  # the checkpoint at 500 survives
            raise Killed

    def run(name, steps, **options):
        return expert.train_expert(store, env_id="Hopper-v5", config=budget(steps), seed=3, name=name, device=device, **options)

    for name in ("extended", "stopped"):
        with pytest.raises(Killed):
            run(name, 1200, on_progress=kill)
    with pytest.raises(LwailError, match="at step 500: --steps must be at least 500"):
        run("stopped", 400, resume=True)
    for other in (cfg.with_overrides(budget(1200), ["td3.batch_size=32"]), cfg.with_overrides(budget(1200), ["train.policy=actor"])):
        with pytest.raises(LwailError, match="made with another config"):
            expert.train_expert(store, env_id="Hopper-v5", config=other, seed=3, name="stopped", device=device, resume=True)

    straight, extended = run("straight", 1600), run("extended", 1600, resume=True)
    assert straight.file("final_actor.safetensors").read_bytes() == extended.file("final_actor.safetensors").read_bytes()
    assert pd.read_csv(extended.file("learning_curve.csv"))["step"].tolist() == [1200, 1600]

    stopped = run("stopped", 500, resume=True)
    assert stopped.config["train"]["steps"] == 500 and stopped.metrics["env_steps"] == 500
    assert pd.read_csv(stopped.file("learning_curve.csv"))["step"].tolist() == [500]  # evaluated where it stopped


def test_icvf_pretraining_resumes_after_a_kill_bit_for_bit(store):
    device = torch.device("cpu")
    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=400), seed=0)
    config = cfg.EmbedConfig(icvf=cfg.ICVFConfig(steps=60, hidden=(16,), embedding_dim=8, log_every=10, checkpoint_every=20))
    straight = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="straight", device=device)

    def kill(step, shown):
        if step == 50:  # after the checkpoint at 40: steps 41-50 are lost and redone
            raise Killed

    for name in ("killed", "observed"):
        with pytest.raises(Killed):
            embed.embed(store, data_ref=data.ref, config=config, seed=0, name=name, device=device, on_progress=kill)
    checkpoint = store.runs.load_checkpoint("embedding", "killed")
    assert checkpoint["step"] == 40
    assert set(checkpoint) == {"learner", "torch_rng", "cuda_rng", "rows", "step", "wall_time", "running", "record"}  # as ever
    with pytest.raises(LwailError, match="made with another seed"):
        embed.embed(store, data_ref=data.ref, config=config, seed=1, name="killed", device=device, resume=True)
    with pytest.raises(LwailError, match=r"another config; rerun with the same options \(only icvf.log_every, icvf.checkpoint_every may"):
        embed.embed(store, data_ref=data.ref, config=cfg.with_overrides(config, ["icvf.lr=0.001"]), seed=0, name="killed", device=device, resume=True)
    resumed = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="killed", device=device, resume=True)
    assert straight.file("phi.safetensors").read_bytes() == resumed.file("phi.safetensors").read_bytes()
    assert straight.file("loss.csv").read_text().count("\n") == resumed.file("loss.csv").read_text().count("\n") == 7
    assert not store.runs.has_checkpoint("embedding", "killed")
    # logging and checkpointing on another schedule changes nothing trained, and each logged loss is the mean since the last row
    observed_config = cfg.with_overrides(config, ["icvf.log_every=15", "icvf.checkpoint_every=7"])
    observed = embed.embed(store, data_ref=data.ref, config=observed_config, seed=0, name="observed", device=device, resume=True)
    assert straight.file("phi.safetensors").read_bytes() == observed.file("phi.safetensors").read_bytes()
    straight_loss = pd.read_csv(straight.file("loss.csv")).set_index("step")["loss"]
    observed_loss = pd.read_csv(observed.file("loss.csv")).set_index("step")["loss"]
    assert observed_loss.index.tolist() == [10, 20, 30, 40, 45, 60]  # logged every 10 before the kill, every 15 after it
    assert observed_loss.loc[:40].tolist() == straight_loss.loc[:40].tolist()
    # steps 41-60 summed: 41-45 and 46-60 here, 41-50 and 51-60 in the straight run
    assert 5 * observed_loss[45] + 15 * observed_loss[60] == pytest.approx(10 * straight_loss[50] + 10 * straight_loss[60])


def test_a_killed_run_is_neither_overwritten_nor_run_twice(store):
    import socket
    import subprocess

    config = _expert_config(1200, 500)
    train = dict(env_id="InvertedPendulum-v5", config=config, seed=3, name="run", device=torch.device("cpu"))

    def kill(step, shown):
        if step == 1000:
            raise Killed

    with pytest.raises(Killed):
        expert.train_expert(store, on_progress=kill, **train)
    checkpoint = store.root / ".runs" / "policy" / "run" / "checkpoint.pt"
    saved = checkpoint.read_bytes()
    with pytest.raises(LwailError, match="left a checkpoint: add --resume to continue it"):
        expert.train_expert(store, **train)
    assert checkpoint.read_bytes() == saved
    lock = checkpoint.parent / "lock"
    with subprocess.Popen(["sleep", "30"]) as other:  # another live process holds the run
        lock.write_text(f"{socket.gethostname()} {other.pid}")
        with pytest.raises(LwailError, match=f"being trained by process {other.pid}"):
            expert.train_expert(store, resume=True, **train)
        other.kill()
    other.wait()
    assert expert.train_expert(store, resume=True, **train).metrics["env_steps"] == 1200  # a dead owner's lock is taken over
    assert not checkpoint.parent.exists()


def test_a_policy_loads_in_python_and_predicts_like_sb3(store):
    import gymnasium as gym

    import lwail_cli

    config = _expert_config(400, 400)
    trained = expert.train_expert(store, env_id="InvertedPendulum-v5", config=config, seed=0, name="p", device=torch.device("cpu"))
    policy = lwail_cli.load_policy("p", store=store.root)
    env = gym.make("InvertedPendulum-v5")
    obs, _ = env.reset(seed=0)  # float64, as gymnasium gives it
    action, state = policy.predict(obs, deterministic=True)
    assert action.shape == (1,) and state is None and env.action_space.contains(action.astype(np.float32))
    batch, _ = policy.predict(np.stack([obs, obs * 0.5]))
    assert batch.shape == (2, 1) and np.allclose(batch[0], action, atol=1e-6)
    with torch.no_grad():
        expected = load_policy(trained)(torch.as_tensor(obs, dtype=torch.float32)).numpy()
    assert np.allclose(action, expected, atol=1e-6)


def test_embeddings_rewards_and_episodes_load_in_python(store):
    import lwail_cli

    bundled, data, embedding, disc = _pendulum_chain(store, 400, cfg.ICVFConfig(steps=20, hidden=(16,), embedding_dim=8, log_every=20), 5)

    expert = lwail_cli.load_episodes(bundled.ref, store=store.root)
    with np.load(demos.bundled_demos_path("InvertedPendulum-v5")) as shipped:
        assert np.array_equal(expert["observations"], shipped["observations"]) and np.array_equal(expert["episode_ends"], shipped["episode_ends"])
    random = lwail_cli.load_episodes(data.ref, store=store.root)
    assert len(random["observations"]) == 400 + random["episode_ends"].sum()  # one more observation than steps per episode

    phi = lwail_cli.load_embedding(embedding.ref, store=store.root)
    latents = phi(random["observations"][:5].astype(np.float64))
    assert latents.shape == (5, 8) and np.allclose(phi(random["observations"][0]), latents[0], atol=1e-6)

    reward = lwail_cli.load_reward(disc.ref, store=store.root)
    first = slice(0, int(np.flatnonzero(expert["episode_ends"])[0]) + 1)  # the warm-up's expert pairs: episode one
    observations = expert["observations"][first]
    rewards = reward(observations[:-1], observations[1:])
    assert rewards.shape == (len(observations) - 1,) and np.all((rewards > 0) & (rewards < 1))
    assert float(rewards.mean()) == pytest.approx(disc.metrics["reward_expert_mean"], abs=1e-5)


def test_evals_csv_keeps_one_set_of_columns_whether_or_not_normalized(store):
    import pandas as pd

    policy = expert.train_expert(store, env_id="InvertedPendulum-v5", config=_expert_config(400, 400), seed=0, device=torch.device("cpu"))
    evaluate.evaluate(store, policy_ref=policy.ref, config=cfg.EvalConfig(episodes=1))
    evaluate.evaluate(store, policy_ref=policy.ref, config=cfg.EvalConfig(episodes=1), normalized=True)
    rows = pd.read_csv(policy.path / "evals.csv")
    assert len(rows) == 2 and rows["normalized_score"].isna().tolist() == [True, False]
    header, *lines = (policy.path / "evals.csv").read_text().splitlines()
    assert len(lines) == 2 and all(line.count(",") == header.count(",") for line in lines)  # one header fits both rows
    assert {"return_mean", "normalized_score", "reference"} <= set(header.split(","))
    assert rows["return_mean"].iloc[0] == rows["return_mean"].iloc[1] and rows["reference"].isna().tolist() == [True, False]


def test_evaluating_a_read_only_policy_still_reports_its_score(cli, store, monkeypatch):
    from lwail_cli.artifacts import Artifact

    policy = expert.train_expert(store, env_id="InvertedPendulum-v5", config=_expert_config(400, 400), seed=0, device=torch.device("cpu"))

    def read_only(self, filename, row):
        raise PermissionError(13, "Permission denied", str(self.path / filename))

    with monkeypatch.context() as patch:
        patch.setattr(Artifact, "append_log", read_only)
        result = cli("eval", policy.ref, "--episodes", "1")
    assert result.exit_code == 0 and "return" in result.output
    assert "warning: not appended to evals.csv: Permission denied" in result.output
    assert not (policy.path / "evals.csv").exists()
    # the same evaluation of a writable policy: the score reported is the one it gives
    expected = evaluate.evaluate(store, policy_ref=policy.ref, config=cfg.EvalConfig(episodes=1))
    assert f"{policy.ref}: return {expected['return_mean']:.1f} ± 0.0 over 1 episodes" in result.output.splitlines()


def test_a_replay_buffer_that_cannot_fit_is_refused_before_anything_runs(cli, store, monkeypatch):
    from conftest import committed_versions
    from lwail_cli.stages import shared

    monkeypatch.setattr(shared, "available_memory", lambda: 2**29)
    # 10M transitions x (11 + 3 + 11 + 2) float32 = 1.0 GiB, with 0.5 GiB available
    result = cli("expert", "train", "Hopper-v5", "--steps", "10000000", "--set", "td3.buffer_size=10000000", "--name", "huge")
    assert result.exit_code == 1, result.output
    assert "a replay buffer of 10000000 transitions needs 1.0 GiB of memory, 0.5 GiB is available" in result.output
    assert committed_versions(store) == [] and not store.runs.has_checkpoint("policy", "huge")
    result = cli("collect", "Hopper-v5", "--transitions", "10000000")
    assert result.exit_code == 1 and "collecting 10000000 transitions needs" in result.output and committed_versions(store) == []
