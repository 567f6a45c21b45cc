"""`lwail quickstart`: its settings declared as a sweep plan's are (defaults, the bundled preset, --set STAGE:field=value),
checked whole before anything runs, and the same for its default call as before the preset existed."""

import hashlib
import json

import pytest

from conftest import committed_versions
from lwail_cli import config as cfg
from lwail_cli.stages.curve import reward_of
from lwail_cli.stages.declaration import PLAN_STAGES, preset, presets
from lwail_cli.stages.quickstart import QUICK_ENV, quickstart_configs
from lwail_cli.stages.sweep_plan import plan_from_dict

# each stage's config of the default call, as quickstart built them by hand before its preset (commit 45caa73), less
# the settings a run does not read (other methods' and embedding kinds' sections: settings.section's used_when)
BEFORE = {"InvertedPendulum-v5": "7b781587768eff3e", "Hopper-v5": "7ac581e295ff3209"}
TINY = ["collect:transitions=400", "pretrain-icvf:icvf.steps=20", "pretrain-icvf:icvf.hidden=(32,)", "pretrain-icvf:icvf.embedding_dim=16",
        "imitate:train.eval_every=150", "imitate:train.eval_episodes=1", "imitate:td3.random_steps=150",
        "imitate:td3.learning_starts=150", "imitate:td3.batch_size=64", "imitate:td3.hidden=(32, 32)", "imitate:update_every=150", "imitate:update_steps=2", "eval:episodes=2"]


@pytest.mark.parametrize("env_id", sorted(BEFORE))
def test_the_default_call_builds_the_configs_it_built_before(env_id):
    configs = quickstart_configs(env_id)
    built = {stage: cfg.to_dict(configs[stage]) for stage in PLAN_STAGES}
    assert hashlib.sha256(json.dumps(built, sort_keys=True).encode()).hexdigest()[:16] == BEFORE[env_id]


def test_the_preset_is_a_plans_set_and_builds_what_a_sweep_of_it_would():
    assert set(presets()) == {QUICK_ENV} and preset("Hopper-v5") == {}  # any other task: the stages' defaults
    table = preset(QUICK_ENV)
    plan = plan_from_dict({"name": "q", "tasks": [QUICK_ENV], "seeds": [0], "embeddings": ["icvf"],
                           "set": {stage: list(assignments) for stage, assignments in table.items()}}, "test plan")
    configs = quickstart_configs(QUICK_ENV)
    assert all(plan.config(stage, "icvf") == configs[stage] for stage in PLAN_STAGES)
    assert configs["imitate"].update_every == 2000 and configs["pretrain-icvf"].icvf.steps == 1000


def test_set_goes_over_the_preset_one_stage_at_a_time():
    configs = quickstart_configs(QUICK_ENV, ["imitate:update_every=3000", "warmup-disc:steps=7", "imitate:train.steps=9000"])
    assert (configs["imitate"].update_every, configs["warmup-disc"].steps, configs["imitate"].train.steps) == (3000, 7, 9000)
    assert configs["imitate"].td3.random_steps == 2000 and configs["warmup-disc"].expert_episodes == 1  # the preset's and the default


@pytest.mark.parametrize("arguments, message", [
    (["--set", "update_every=3000"], "--set update_every=3000: name the stage, STAGE:update_every=3000 (stages with update_every: imitate)"),
    (["--set", "steps=5"], "(stages with steps: warmup-disc)"),
    (["--set", "td3.nope=5"], "(no stage has td3.nope: `lwail defaults STAGE` lists each one's)"),
    (["--set", "imitat:update_every=3000"], "unknown stage 'imitat'; the stages are collect, pretrain-icvf, warmup-disc, imitate, eval"),
    (["--set", "imitate:td3.nope=1"], "--set td3.nope: unknown setting 'nope'"),
    (["--set", "imitate:td3.gamma=2"], "td3.gamma must be below 1.0, got 2.0"),
    (["--steps", "100", "--set", "imitate:train.steps=200"], "--set train.steps is given twice (200 and 100); give it once"),
    (["--set", "imitate:method=pwil", "--set", "warmup-disc:steps=5"], "the method pwil runs no warmup-disc stage"),
    (["--env", "Swimmer-v5"], "no bundled demos for Swimmer-v5"),
])
def test_a_bad_setting_is_one_line_before_anything_runs(cli, store, arguments, message):
    result = cli("quickstart", *arguments)
    assert result.exit_code == 1 and message in result.output and len(result.output.strip().splitlines()) == 1, result.output
    assert committed_versions(store) == []


def test_quickstart_runs_the_chain_of_its_method_with_the_settings_given(cli, store):
    result = cli("quickstart", "--device", "cpu", "--steps", "300", "--set", "imitate:method=pwil", *(f"--set={a}" for a in TINY))
    assert result.exit_code == 0, result.output
    kinds = [kind for kind, *_ in committed_versions(store)]
    assert "discriminator" not in kinds and kinds.count("policy") == 1  # PWIL reads no f: no warm-up
    policy = store.resolve("invertedpendulum-v5-pwil", "policy")
    assert (policy.config["method"], policy.config["train"]["steps"], policy.config["train"]["eval_every"]) == ("pwil", 300, 150)
    assert "update_every" not in policy.config  # given, but PWIL's reward has no update schedule: not recorded
    assert policy.config["train"]["checkpoint_every"] == 25000  # the preset's, under the --set
    assert reward_of(store, policy.name) == "α·exp(−β·T·c/√d)"  # what `lwail curve` names its reward
