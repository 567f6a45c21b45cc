"""A config key that changes nothing is a bug: every field of every stage's config must be read by the code."""

import dataclasses

import pytest
import torch

from lwail_cli import config as cfg
from lwail_cli.embeddings import EMBEDDINGS
from lwail_cli.stages import collect, demos, embed, evaluate, expert, imitate, warmup

ENV = "InvertedPendulum-v5"


def _config_types():
    seen, todo = set(), list(cfg.STAGES.values())
    while todo:
        config_type = todo.pop()
        if config_type in seen:
            continue
        seen.add(config_type)
        todo += [f.default_factory for f in dataclasses.fields(config_type) if f.default is dataclasses.MISSING]
    return seen


@pytest.fixture
def reads(monkeypatch):
    """Record every field read through attribute access (recording and validation go through ``vars``)."""
    seen = set()
    for config_type in _config_types():
        names = set(config_type.__dataclass_fields__)

        def getattribute(self, name, names=names, owner=config_type.__name__):
            if name in names:
                seen.add((owner, name))
            return object.__getattribute__(self, name)

        monkeypatch.setattr(config_type, "__getattribute__", getattribute)
    return seen


def test_every_config_field_of_every_stage_is_read(store, reads):
    device = torch.device("cpu")
    td3 = cfg.TD3Config(hidden=(16,), random_steps=200, learning_starts=200, batch_size=32)
    train = cfg.TrainConfig(steps=400, eval_every=400, eval_episodes=1, checkpoint_every=200)
    policy = expert.train_expert(store, env_id=ENV, config=cfg.ExpertConfig(td3=td3, train=train), seed=0, device=device)
    recorded = demos.record_demos(store, policy_ref=policy.ref, config=cfg.RecordConfig(episodes=2), seed=0)
    data = collect.collect(store, env_id=ENV, config=cfg.CollectConfig(transitions=300), seed=0)
    icvf = cfg.ICVFConfig(steps=4, batch_size=8, hidden=(8,), embedding_dim=8, log_every=2)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=device)
    # the other trained embeddings' settings, each read by its own kind
    for kind in [name for name, entry in EMBEDDINGS.items() if entry.trained and name != "icvf"]:
        contrastive = [f"kind={kind}", f"{kind}.steps=4", f"{kind}.batch_size=8", f"{kind}.hidden=8", f"{kind}.embedding_dim=8", f"{kind}.log_every=2"]
        embed.embed(store, data_ref=data.ref, config=cfg.with_overrides(cfg.EmbedConfig(), contrastive), seed=0, device=device)
    warm = cfg.WarmupConfig(critic=cfg.CriticConfig(hidden=(8,)), steps=2, transitions=50)
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=recorded.ref, config=warm, seed=0, device=device)
    config = cfg.ImitationConfig(td3=td3, train=train, update_every=200, update_steps=1)
    learner = imitate.imitate(store, env_id=ENV, demos_ref=recorded.ref, embedding_ref=embedding.ref, disc_ref=disc.ref,
                              config=config, seed=0, device=device)
    evaluate.evaluate(store, policy_ref=learner.ref, config=cfg.EvalConfig(episodes=1))
    for method in [name for name in cfg.METHODS if name != "lwail"]:  # the baselines' own settings (methods/)
        imitate.imitate(store, env_id=ENV, demos_ref=recorded.ref, embedding_ref=embedding.ref, config=cfg.with_overrides(config, [f"method={method}"]),
                        seed=0, device=device, name=method)
    unread = sorted(
        f"{config_type.__name__}.{name}"
        for config_type in _config_types() for name in config_type.__dataclass_fields__
        if (config_type.__name__, name) not in reads
    )
    assert not unread, f"config fields no code reads: {unread}"
