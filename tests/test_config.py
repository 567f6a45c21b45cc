import pytest

from lwail_cli import config as cfg
from lwail_cli.errors import LwailError


def test_override_nested_fields_with_their_types():
    config = cfg.with_overrides(cfg.ImitationConfig(), ["td3.actor_lr=1e-4", "disc.hidden=32,32", "disc.tanh=true", "train.steps=5000"])
    assert config.td3.actor_lr == 1e-4
    assert config.disc.hidden == (32, 32)
    assert config.disc.tanh is True
    assert config.train.steps == 5000
    assert cfg.ImitationConfig().td3.actor_lr == 3e-4  # defaults untouched


def test_config_round_trips_through_a_manifest_dict():
    config = cfg.with_overrides(cfg.ImitationConfig(), ["disc.hidden=16", "expert_episodes=3"])
    assert cfg.from_dict(cfg.ImitationConfig, cfg.to_dict(config)) == config


@pytest.mark.parametrize(
    "assignment, message",
    [("td3.nope=1", "unknown setting 'nope'"), ("td3=1", "is a section"), ("td3.batch_size=abc", "cannot read"), ("td3.batch_size", "section.field=value")],
)
def test_bad_overrides_are_refused(assignment, message):
    with pytest.raises(LwailError, match=message):
        cfg.with_overrides(cfg.ImitationConfig(), [assignment])
