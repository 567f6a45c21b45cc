import dataclasses
import json

import pytest

from lwail_cli import config as cfg
from lwail_cli.embeddings import EMBEDDINGS
from lwail_cli.errors import LwailError


def test_override_nested_fields_with_their_types():
    config = cfg.with_overrides(cfg.ImitationConfig(), ["td3.actor_lr=1e-4", "td3.hidden=32,32", "update_every=2000", "train.steps=5000"])
    assert config.td3.actor_lr == 1e-4
    assert config.td3.hidden == (32, 32)
    assert config.update_every == 2000
    assert config.train.steps == 5000
    assert cfg.ImitationConfig().td3.actor_lr == 3e-4  # defaults untouched
    warm = cfg.with_overrides(cfg.WarmupConfig(), ["critic.tanh=true", "critic.hidden=16"])
    assert warm.critic.tanh is True and warm.critic.hidden == (16,)


def test_a_manifest_of_an_older_lwail_reads_layer_norm_as_the_placement_it_used():
    assert cfg.from_dict(cfg.ICVFConfig, {"layer_norm": True}).layer_norm == "before"  # LayerNorm before each GELU
    assert cfg.from_dict(cfg.ICVFConfig, {"layer_norm": False}).layer_norm == "none"
    assert cfg.with_overrides(cfg.EmbedConfig(), ["icvf.layer_norm=false"]).icvf.layer_norm == "none"  # older plans
    with pytest.raises(LwailError, match="icvf.layer_norm must be one of none, after, before, got 'middle'"):
        cfg.with_overrides(cfg.EmbedConfig(), ["icvf.layer_norm=middle"])


def test_config_round_trips_through_a_manifest_dict():
    config = cfg.with_overrides(cfg.ImitationConfig(), ["td3.hidden=16", "expert_episodes=3"])
    assert cfg.from_dict(cfg.ImitationConfig, cfg.to_dict(config)) == config


@pytest.mark.parametrize("method", cfg.METHODS)
def test_an_imitation_record_holds_the_running_methods_settings_alone(method):
    """A record (manifest, resume check, sweep fingerprint) keeps only what its run reads, so adding a method leaves
    every other method's records, and the sweeps that fingerprint them, as they were."""
    config = cfg.ImitationConfig(method=method)
    record = cfg.to_dict(config)
    # lwail's settings are top-level; OPOLO's reward is GAIfO's D, so it reads gaifo.* too
    assert {name for name in cfg.METHODS if name in record} == ({method} - {"lwail"}) | ({"gaifo"} if method == "opolo" else set())
    assert ("update_every" in record) == ("update_steps" in record) == (method in cfg.ADVERSARIAL)
    assert {"env", "td3", "train", "method", "expert_episodes"} <= set(record)
    assert cfg.from_dict(cfg.ImitationConfig, record) == config


@pytest.mark.parametrize("kind", cfg.EMBEDDING_KINDS)
def test_an_embedding_config_records_the_section_its_kind_reads_alone(kind):
    record = cfg.to_dict(cfg.EmbedConfig(kind=kind))
    reads = {"identity": "icvf"}.get(kind, kind)  # the identity's probe reads icvf.holdout_fraction
    assert set(record) == {"kind", reads}


@pytest.mark.parametrize(
    "assignment, message",
    [
        ("td3.nope=1", "unknown setting 'nope'"),
        ("td3=1", "is a section"),
        ("td3.batch_size=abc", "cannot read"),
        ("td3.batch_size", "section.field=value"),
        ("td3.batch_size=2.5", "cannot read"),
        ("td3.gamma=nan", "td3.gamma must be finite"),
        ("td3.gamma=1.5", "td3.gamma must be below 1"),
        ("td3.actor_lr=inf", "td3.actor_lr must be finite"),
        ("td3.actor_lr=1e8", "td3.actor_lr must be at most 1"),
        ("td3.hidden=0,64", "td3.hidden must be at least 1"),
        ("td3.policy_delay=0", "td3.policy_delay must be at least 1"),
        ("td3.batch_size=5000", "td3.learning_starts \\(4000\\) must be at least td3.batch_size"),
        ("train.eval_every=0", "train.eval_every must be at least 1"),
        ("train.checkpoint_every=-3", "train.checkpoint_every must be at least 1"),
        ("train.steps=1e12", "train.steps must be at most"),
        ("update_every=0", "imitation.update_every must be at least 1"),
    ],
)
def test_bad_overrides_are_refused_with_the_field_named(assignment, message):
    with pytest.raises(LwailError, match=message):
        cfg.with_overrides(cfg.ImitationConfig(), [assignment])


def test_icvf_goal_probabilities_must_leave_room_for_random_goals():
    with pytest.raises(LwailError, match="p_goal_current \\+ icvf.p_goal_trajectory must be at most 1"):
        cfg.ICVFConfig(p_goal_current=0.6, p_goal_trajectory=0.5)
    with pytest.raises(LwailError, match="icvf.expectile must be at most 1"):
        cfg.with_overrides(cfg.EmbedConfig(), ["icvf.expectile=1.5"])
    with pytest.raises(LwailError, match="embed.kind must be one of icvf, identity"):
        cfg.EmbedConfig(kind="pca")


def _fields(config_type, prefix=""):
    for f in dataclasses.fields(config_type):
        hint = config_type.__dataclass_fields__[f.name].default_factory if f.default is dataclasses.MISSING else None
        if hint is not None and dataclasses.is_dataclass(hint):
            yield from _fields(hint, f"{prefix}{f.name}.")
        else:
            yield config_type, f


@pytest.mark.parametrize("stage", sorted(cfg.STAGES))
def test_every_field_has_a_doc_and_defaults_describe_it(stage):
    config_type = cfg.STAGES[stage]
    for owner, f in _fields(config_type):
        assert f.metadata.get("doc"), f"{owner.__name__}.{f.name} has no one-line doc"
        assert "\n" not in f.metadata["doc"]
    described = cfg.describe(config_type())
    assert all(f"{f.name} = " in described for _, f in _fields(config_type))
    lines = [line.strip() for line in described.splitlines()]
    for owner, f in _fields(config_type):  # a line `name = default  # doc` of this field: its own default and doc
        default = getattr(owner(), f.name)
        expected = list(default) if isinstance(default, tuple) else default
        assert any(line.startswith(f"{f.name} = ") and line.endswith(f"  # {f.metadata['doc']}")
                   and json.loads(line[len(f"{f.name} = "):-len(f"  # {f.metadata['doc']}")]) == expected for line in lines), \
            f"{owner.__name__}.{f.name}: no line '{f.name} = {default!r}  # ...' in\n{described}"


def test_the_settings_a_resume_may_change_are_declared_on_them_and_listed_in_the_resume_help():
    """The budget and how a run is watched (logged, evaluated, checkpointed), in every section; nothing that trains."""
    from lwail_cli.cli.app import resume_option

    online = ("train.steps", "train.eval_every", "train.eval_episodes", "train.checkpoint_every", "train.average_tau")
    assert cfg.resume_may_change(cfg.ExpertConfig) == cfg.resume_may_change(cfg.ImitationConfig) == online
    embedded = tuple(f"{kind}.{key}" for kind, entry in EMBEDDINGS.items() if entry.trained for key in ("log_every", "checkpoint_every"))
    assert cfg.resume_may_change(cfg.EmbedConfig) == embedded  # each trained embedding's own section
    assert f"{embedded[-2]} and {embedded[-1]} may differ." in resume_option(cfg.EmbedConfig, "pre-training").help
    assert "train.checkpoint_every and train.average_tau may differ" in resume_option(cfg.ImitationConfig, "run").help


def _leaves(config_class: type, prefix: str = "", added: bool = False) -> list[tuple[str, bool]]:
    """Every leaf field (``section.field``) of a config class, and whether it (or its section) is declared ``since``."""
    import typing

    hints, leaves = typing.get_type_hints(config_class), []
    for f in dataclasses.fields(config_class):
        since = added or f.metadata.get("since") is not None
        if dataclasses.is_dataclass(hints[f.name]):
            leaves += _leaves(hints[f.name], f"{prefix}{f.name}.", since)
        else:
            leaves.append((f"{prefix}{f.name}", since))
    return leaves


def test_every_field_lwail_0_3_did_not_have_says_since_when():
    """A sweep finds the stages lwail 0.3 finished under 0.3's record (every field, none added since): a field added
    without ``since`` would change that record, and an upgraded sweep would rerun every finished run."""
    from pathlib import Path

    layout_0_3 = json.loads((Path(__file__).parent / "data" / "config-layout-0.3.json").read_text())  # 0.3's STAGES, as 45caa73 declared them
    assert set(layout_0_3) == set(cfg.STAGES)
    for stage, config_class in cfg.STAGES.items():
        assert sorted(path for path, since in _leaves(config_class) if not since) == sorted(layout_0_3[stage]), stage
    assert [path for path, since in _leaves(cfg.ImitationConfig) if since] == [
        f"{method}.{f.name}" for method, config in (("bco", cfg.BcoConfig), ("opolo", cfg.OpoloConfig), ("difo", cfg.DifoConfig))
        for f in dataclasses.fields(config)]


def test_the_record_of_0_3_holds_every_section_read_or_not_and_none_added_since():
    lwail = cfg.ImitationConfig()
    as_0_3 = cfg.recorded_by_0_3(lwail)
    assert as_0_3 == cfg.to_dict(lwail) | {
        "gaifo": cfg.to_dict(cfg.GaifoConfig()), "pwil": cfg.to_dict(cfg.PwilConfig())}
    # a setting added since, unread by this method, leaves the record alone; read with another value, no 0.3 run matches
    assert cfg.recorded_by_0_3(cfg.with_overrides(lwail, ["bco.lr=0.01"])) == as_0_3
    assert cfg.recorded_by_0_3(cfg.with_overrides(lwail, ["method=bco", "bco.lr=0.01"])) is None
    assert cfg.recorded_by_0_3(cfg.with_overrides(lwail, ["opolo.alpha=0.5"])) == as_0_3
    assert cfg.recorded_by_0_3(cfg.with_overrides(lwail, ["method=opolo", "opolo.alpha=0.5"])) is None
    assert cfg.recorded_by_0_3(cfg.EmbedConfig(kind="icvf")).keys() == {"kind", "icvf", "infonce", "curl"}
