"""Flags that stand for settings (`--steps` is `--set train.steps`), and the one learning-curve file name."""

import pandas as pd
import pytest

from lwail_cli import config as cfg
from lwail_cli.cli import shorthands
from lwail_cli.envs import describe_env
from lwail_cli.errors import LwailError
from lwail_cli.stages import collect, demos, embed, evaluate, expert, imitate, warmup

ENV = "InvertedPendulum-v5"
COMMANDS = {  # command line (before its flags) -> its config class and the stage function it hands the config to
    "collect": (("collect", ENV), cfg.CollectConfig, collect, "collect"),
    "expert train": (("expert", "train", ENV), cfg.ExpertConfig, expert, "train_expert"),
    "expert record": (("expert", "record", "p"), cfg.RecordConfig, demos, "record_demos"),
    "demos import": (("demos", "import", ENV, "--from-sb3", "model.zip"), cfg.RecordConfig, demos, "import_sb3_demos"),
    "pretrain-icvf": (("pretrain-icvf", "data"), cfg.EmbedConfig, embed, "embed"),
    "warmup-disc": (("warmup-disc", "e", "d"), cfg.WarmupConfig, warmup, "warmup"),
    "imitate": (("imitate", ENV, "--demos", "d", "--embedding", "e", "--disc", "f"), cfg.ImitationConfig, imitate, "imitate"),
    "eval": (("eval", "p"), cfg.EvalConfig, evaluate, "evaluate"),
}
CASES = [(command, shorthand) for command, (_, config_type, _, _) in COMMANDS.items() for shorthand in shorthands.shorthands(config_type())]


class Captured(LwailError):
    pass


@pytest.fixture
def configured(cli, monkeypatch):
    """Run a command up to its stage and return the config the stage was given (or the command's output if refused)."""

    def run(command: str, *flags: str):
        args, _, module, function = COMMANDS[command]
        seen = []

        def stage(*_, config, **__):
            seen.append(config)
            raise Captured("stage reached")

        monkeypatch.setattr(module, function, stage)
        result = cli(*args, *flags)
        assert result.exit_code == 1, result.output
        return seen[0] if seen else result.output.strip()

    return run


TEXT_VALUES = {"kind": "identity", "method": "gaifo"}  # the text flags (--kind, --method): another choice


def _other_value(shorthand: shorthands.Shorthand) -> str:
    """A value the setting accepts that is not its default."""
    return TEXT_VALUES[shorthand.key] if shorthand.key in TEXT_VALUES else str(shorthand.default + 1)


def _value(config, key: str):
    for part in key.split("."):
        config = getattr(config, part)
    return config


@pytest.mark.parametrize("command, shorthand", CASES, ids=[f"{command} {shorthand.flag}" for command, shorthand in CASES])
def test_each_flag_sets_its_key_as_its_set_does(configured, command, shorthand):
    value = _other_value(shorthand)
    by_flag = configured(command, shorthand.flag, value)
    assert str(_value(by_flag, shorthand.key)) == value
    assert configured(command, "--set", f"{shorthand.key}={value}") == by_flag
    assert configured(command, shorthand.flag, value, "--set", f"{shorthand.key}={value}") == by_flag  # agreeing is fine
    assert configured(command) == COMMANDS[command][1]()  # neither: the setting's default


def test_a_flag_and_a_set_of_its_key_that_disagree_are_refused(configured, store):
    assert configured("expert train", "--steps", "5000", "--set", "train.steps=6000") == "error: --steps 5000 and --set train.steps=6000 disagree"
    assert configured("pretrain-icvf", "--kind", "identity", "--set", "kind=icvf") == "error: --kind identity and --set kind=icvf disagree"
    assert configured("expert train", "--steps", "5000", "--set", "train.steps=5e3").train.steps == 5000  # one number, two spellings
    assert store.list() == []


def test_a_flag_of_another_section_is_no_conflict(configured):
    config = configured("imitate", "--steps", "5000", "--set", "td3.batch_size=64", "--set", "train.eval_every=100")
    assert (config.train.steps, config.train.eval_every, config.td3.batch_size) == (5000, 100, 64)
    assert configured("imitate", "--steps", "0") == "error: train.steps must be at least 1, got 0"


def test_help_shows_each_flag_with_its_key_and_the_settings_default(cli):
    result = cli("imitate", "--help")
    assert result.exit_code == 0, result.output
    shown = " ".join(result.output.replace("│", " ").split())
    for key, default in (("train.steps", 1_000_000), ("train.eval_every", 10_000), ("expert_episodes", 1)):
        assert shown.count(f"--set {key}:") == 1, shown
        entry = shown.split(f"--set {key}:")[1].split(" --")[0]  # this flag's own help, up to the next option
        assert entry.strip().endswith(f"[default: {default}]"), entry


# ------------------------------------------------------------------------------ the learning curve's file
ROWS = [{"step": 500, "wall_time": 1.0, "return_mean": 10.0, "return_std": 1.0, "episodes_terminated": 0},
        {"step": 1000, "wall_time": 2.0, "return_mean": 20.0, "return_std": 2.0, "episodes_terminated": 1}]


def test_a_curve_written_under_the_old_name_is_still_read(cli, store):
    """`expert train` up to 9b43183 named its curve training.csv, in the run folder and in the policy artifact."""
    store.runs.write_run_log("policy", "killed", "training.csv", ROWS)
    killed = cli("curve", "killed", "--out", store.root / "killed.png")
    assert killed.exit_code == 0, killed.output
    assert "training.csv" in killed.output and "kept network, return_mean over 1000 steps: last 20.0" in killed.output
    assert f"wrote {store.root / 'killed.png'}" in killed.output
    assert (store.root / "killed.png").read_bytes().startswith(b"\x89PNG\r\n\x1a\n")

    with store.create("policy", "old", env=describe_env(ENV), config={}, seed=0) as writer:
        pd.DataFrame(ROWS).to_csv(writer.path("training.csv"), index=False)
    finished = cli("curve", "old", "--out", store.root / "old.png")
    assert finished.exit_code == 0, finished.output
    assert finished.output.startswith("policy/old@v1: ") and "training.csv" in finished.output
    assert "kept network, return_mean over 1000 steps: last 20.0" in finished.output  # the old file's rows, read
    assert (store.root / "old.png").read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
