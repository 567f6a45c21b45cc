"""The embedding registry (embeddings.py) and its contrastive entries, each run through the same checks."""

import json
import math

import numpy as np
import pandas as pd
import pytest
import torch
from safetensors.torch import load_file

from lwail_cli import config as cfg
from lwail_cli.contrastive import info_nce
from lwail_cli.curl import pretrain_curl
from lwail_cli.embeddings import EMBEDDINGS, embedding, unread_settings
from lwail_cli.errors import LwailError, RunPaused
from lwail_cli.infonce import pretrain_infonce
from lwail_cli.loaders import load_encoder
from lwail_cli.stages import collect, embed
from lwail_cli.stages.sweep_plan import plan_from_dict

from conftest import write_states_npz
from test_lwail import chain_episodes

ENV = "InvertedPendulum-v5"
CONTRASTIVE = {"infonce": pretrain_infonce, "curl": pretrain_curl}
TINY = {"steps": 300, "batch_size": 64, "hidden": (32,), "embedding_dim": 16, "log_every": 100}


def test_every_embedding_kind_has_one_entry_and_its_own_settings_section():
    assert tuple(EMBEDDINGS) == cfg.EMBEDDING_KINDS
    defaults = cfg.EmbedConfig()
    for name, entry in EMBEDDINGS.items():
        assert entry.name == name
        if entry.trained:
            assert type(vars(defaults)[name]) is entry.settings_class and entry.pretrain is not None
    with pytest.raises(LwailError, match="unknown embedding kind 'pca'"):
        embedding("pca")


def test_a_sweep_plan_takes_every_registered_kind_as_an_arm():
    kinds = list(EMBEDDINGS)
    plan = plan_from_dict({"name": "x", "tasks": [ENV], "seeds": [0], "embeddings": [*kinds, "wide"],
                           "variants": {"wide": {"kind": "infonce", "pretrain-icvf": ["infonce.embedding_dim=512"]}}}, "test plan")
    assert [plan.config("pretrain-icvf", arm).kind for arm in plan.kinds] == [*kinds, "infonce"]
    assert plan.config("pretrain-icvf", "wide").infonce.embedding_dim == 512
    with pytest.raises(LwailError, match=f"needs kind = one of {kinds}".replace("[", "\\[").replace("]", "\\]")):
        plan_from_dict({"name": "x", "tasks": [ENV], "seeds": [0], "embeddings": ["pca"], "variants": {"pca": {"kind": "pca"}}}, "test plan")


def test_info_nce_is_low_when_each_anchor_meets_its_own_positive_and_high_when_shuffled():
    anchors = 10 * torch.eye(8)  # orthogonal codes: under W = I each anchor scores 100 with itself, 0 with the others
    assert info_nce(anchors, anchors, torch.eye(8), 1.0) < 1e-3
    shuffled = info_nce(anchors, anchors.roll(1, 0), torch.eye(8), 1.0)
    assert shuffled > 50
    assert info_nce(anchors, anchors.roll(1, 0), torch.eye(8), 1e3) == pytest.approx(math.log(8), abs=0.2)  # hot: near chance


@pytest.mark.parametrize("kind", CONTRASTIVE)
def test_contrastive_loss_falls_well_below_chance_and_phi_has_the_configured_shape(kind):
    config = getattr(cfg.EmbedConfig(), kind).__class__(**TINY)
    result = CONTRASTIVE[kind](chain_episodes(episodes=6, length=40), obs_dim=16, config=config, seed=0)
    losses = result.log["loss"].tolist()
    assert result.log["step"].tolist() == [100, 200, 300]
    assert losses[-1] < losses[0] and losses[-1] < 0.8 * math.log(TINY["batch_size"]), losses  # chance: log(batch)
    latent = result.encoder(torch.zeros(5, 16))
    assert latent.shape == (5, 16) and not latent.requires_grad


@pytest.mark.parametrize("kind", CONTRASTIVE)
def test_contrastive_pretraining_is_deterministic_under_a_seed(kind):
    config = getattr(cfg.EmbedConfig(), kind).__class__(**(TINY | {"steps": 20}))

    def weights(seed):
        encoder = CONTRASTIVE[kind](chain_episodes(episodes=4, length=20), obs_dim=16, config=config, seed=seed).encoder
        return torch.cat([tensor.flatten() for tensor in encoder.state_dict().values()])

    assert torch.equal(weights(0), weights(0)) and not torch.equal(weights(0), weights(1))


class Killed(Exception):
    pass


@pytest.mark.parametrize("kind", CONTRASTIVE)
def test_contrastive_pretraining_resumes_after_a_kill_bit_for_bit(store, kind):
    device = torch.device("cpu")
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=300), seed=0)
    config = cfg.with_overrides(cfg.EmbedConfig(), [f"kind={kind}", f"{kind}.steps=30", f"{kind}.batch_size=32", f"{kind}.hidden=16",
                                                    f"{kind}.embedding_dim=8", f"{kind}.log_every=10", f"{kind}.checkpoint_every=10"])
    straight = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="straight", device=device)

    def kill(step, shown):
        if step == 25:
            raise Killed

    with pytest.raises(Killed):
        embed.embed(store, data_ref=data.ref, config=config, seed=0, name="killed", device=device, on_progress=kill)
    assert store.runs.load_checkpoint("embedding", "killed")["step"] == 20
    with pytest.raises(LwailError, match="made with another config"):
        embed.embed(store, data_ref=data.ref, config=cfg.with_overrides(config, [f"{kind}.lr=0.01"]), seed=0, name="killed", device=device, resume=True)
    resumed = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="killed", device=device, resume=True)
    assert straight.file("phi.safetensors").read_bytes() == resumed.file("phi.safetensors").read_bytes()
    assert straight.config["type"] == kind and straight.config[kind]["embedding_dim"] == 8 and "icvf" not in straight.config


@pytest.mark.parametrize("kind", ["icvf", *CONTRASTIVE])
def test_lwail_pause_stops_a_pretraining_at_its_next_step_and_resume_gives_the_unpaused_phi(store, cli, kind):
    device = torch.device("cpu")
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=300), seed=0)
    config = cfg.with_overrides(cfg.EmbedConfig(), [f"kind={kind}", f"{kind}.steps=30", f"{kind}.batch_size=32", f"{kind}.hidden=16",
                                                    f"{kind}.embedding_dim=8", f"{kind}.log_every=10", f"{kind}.checkpoint_every=10"])
    straight = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="straight", device=device)
    asked = []

    def pause_at_25(step, shown):
        if step == 25:  # between two checkpoints (every 10): what a kill would lose, a pause keeps
            asked.append(cli("pause", "paused").output)

    with pytest.raises(RunPaused, match="paused at step 25 as asked"):
        embed.embed(store, data_ref=data.ref, config=config, seed=0, name="paused", device=device, on_progress=pause_at_25)
    assert asked == ["asked embedding/paused to checkpoint and stop\n"] and store.runs.load_checkpoint("embedding", "paused")["step"] == 25
    resumed = embed.embed(store, data_ref=data.ref, config=config, seed=0, name="paused", device=device, resume=True)
    assert straight.file("phi.safetensors").read_bytes() == resumed.file("phi.safetensors").read_bytes()
    pd.testing.assert_frame_equal(*(pd.read_csv(e.file("loss.csv")).drop(columns="wall_time") for e in (straight, resumed)))


@pytest.mark.parametrize("kind", CONTRASTIVE)
def test_a_contrastive_embedding_feeds_the_chain_from_the_command_line(cli, store, tmp_path, kind):
    write_states_npz(tmp_path / "data.npz", episodes=4, obs_dim=4, length=30)
    assert cli("collect", ENV, "--from-file", tmp_path / "data.npz", "--name", "data").exit_code == 0
    assert cli("demos", "import", ENV, "--bundled", "--name", "demos").exit_code == 0
    made = cli("pretrain-icvf", "data", "--kind", kind, "--set", f"{kind}.steps=5", "--set", f"{kind}.batch_size=16",
               "--set", f"{kind}.hidden=8", "--set", f"{kind}.embedding_dim=6", "--name", "phi")
    assert made.exit_code == 0, made.output
    phi = store.resolve("phi", "embedding")
    assert set(load_file(str(phi.file("phi.safetensors")))) == set(load_encoder(phi).state_dict())
    assert load_encoder(phi)(torch.zeros(3, 4)).shape == (3, 6)
    warmed = cli("warmup-disc", "phi", "demos", "--set", "steps=2", "--set", "critic.hidden=8", "--name", "disc")
    assert warmed.exit_code == 0, warmed.output
    assert json.loads(store.resolve("disc", "discriminator").path.joinpath("manifest.json").read_text())["config"]["input_dim"] == 12
    imitated = cli("imitate", ENV, "--demos", "demos", "--embedding", "phi", "--disc", "disc", "--steps", "200", "--eval-every", "200",
                   "--set", "train.eval_episodes=1", "--set", "td3.hidden=8", "--set", "td3.random_steps=100", "--set", "td3.learning_starts=100",
                   "--set", "td3.batch_size=32", "--set", "update_every=100", "--set", "update_steps=1", "--name", "learner")
    assert imitated.exit_code == 0, imitated.output
    assert store.resolve("learner", "policy").metrics


def test_settings_another_kind_would_read_are_refused_with_one_line(cli, store, tmp_path):
    write_states_npz(tmp_path / "data.npz", episodes=3, obs_dim=4)
    assert cli("collect", ENV, "--from-file", tmp_path / "data.npz", "--name", "data").exit_code == 0
    before = store.list()
    refused = cli("pretrain-icvf", "data", "--kind", "infonce", "--steps", "5")  # --steps is icvf.steps
    assert refused.exit_code == 1
    assert refused.output.strip().splitlines() == [
        "error: --kind infonce does not read icvf.steps; give its own settings as --set infonce.FIELD=VALUE (see `lwail defaults pretrain-icvf`)"]
    bad = cli("pretrain-icvf", "data", "--kind", "infonce", "--set", "infonce.temperature=0")
    assert bad.exit_code == 1 and len(bad.output.strip().splitlines()) == 1 and "infonce.temperature must be at least" in bad.output
    assert cli("pretrain-icvf", "data", "--kind", "infonce", "--set", "infonce.batch_size=1").exit_code == 1  # InfoNCE needs a negative
    noisy = cli("pretrain-icvf", "data", "--kind", "curl", "--set", "curl.noise=-1")
    assert noisy.exit_code == 1 and len(noisy.output.strip().splitlines()) == 1 and "curl.noise must be at least 0" in noisy.output
    assert store.list() == before
    # the identity reads icvf.holdout_fraction (its probe's split), so icvf settings beside it stay accepted, as before
    assert unread_settings(cfg.with_overrides(cfg.EmbedConfig(), ["kind=identity", "icvf.steps=5"])) == []
    assert unread_settings(cfg.with_overrides(cfg.EmbedConfig(), ["kind=icvf", "infonce.lr=0.01"])) == ["infonce.lr"]
    assert unread_settings(cfg.with_overrides(cfg.EmbedConfig(), ["kind=infonce", "curl.noise=0.5"])) == ["curl.noise"]


def test_icvf_and_identity_artifacts_record_and_load_as_before(store):
    """The manifests' records keep the form they had before the registry (so older artifacts load, and new ones
    hash as they did)."""
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=200), seed=0)
    icvf = cfg.ICVFConfig(steps=2, batch_size=8, hidden=(8,), embedding_dim=4, log_every=2)
    trained = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=torch.device("cpu"))
    identity = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, device=torch.device("cpu"))
    assert trained.config == {"type": "icvf", "obs_dim": 4, "embedding_dim": 4, "icvf": cfg.to_dict(icvf)}
    assert identity.config == {"type": "identity", "obs_dim": 4, "embedding_dim": 4}
    states = torch.as_tensor(np.random.default_rng(0).normal(size=(3, 4)), dtype=torch.float32)
    assert torch.equal(load_encoder(identity)(states), states)
    assert load_encoder(trained)(states).shape == (3, 4)
