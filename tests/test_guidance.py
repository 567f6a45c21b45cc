"""What lwail tells a user beside the result: a warning for a budget that cannot train or be watched, the next
commands after quickstart, where figures go, what an import found, what a metric means, and help that reads at 80
columns."""

import pytest

TINY_TD3 = ("--set", "td3.hidden=8", "--set", "td3.batch_size=16", "--set", "train.eval_episodes=1")


def tiny_chain(store):
    """InvertedPendulum's bundled demos, a small random data set, a tiny ICVF φ and a warmed-up f, under quickstart's names."""
    import torch

    from lwail_cli import config as cfg
    from lwail_cli.stages import collect, demos, embed, warmup

    cpu, env = torch.device("cpu"), "InvertedPendulum-v5"
    bundled = demos.import_bundled_demos(store, env_id=env)
    data = collect.collect(store, env_id=env, config=cfg.CollectConfig(transitions=300), seed=0)
    icvf = cfg.ICVFConfig(steps=4, hidden=(8,), embedding_dim=4, batch_size=16, log_every=4)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=cpu)
    disc = warmup.warmup(store, embedding_ref=embedding.ref, demos_ref=bundled.ref, seed=0, device=cpu,
                         config=cfg.WarmupConfig(critic=cfg.CriticConfig(hidden=(8,)), steps=2, transitions=100))
    return bundled, embedding, disc


@pytest.mark.parametrize(
    "budget, warnings",
    [
        (("--steps", "60", "--eval-every", "60", "--set", "td3.learning_starts=16"),
         ["--steps 60 is at most td3.random_steps (10000): every action is uniformly random, the policy kept never acted"]),
        (("--steps", "10", "--eval-every", "10", "--set", "td3.learning_starts=16"),
         ["--steps 10 is below td3.learning_starts (16): TD3 never updates, the policy kept is its untrained initial network"]),
        (("--steps", "60", "--eval-every", "100", "--set", "td3.learning_starts=16", "--set", "td3.random_steps=20"),
         ["--eval-every 100 is above --steps 60: the policy is evaluated once, at the end"]),
        (("--steps", "60", "--eval-every", "30", "--set", "td3.learning_starts=16", "--set", "td3.random_steps=20"), []),
    ],
)
def test_a_budget_that_cannot_train_or_be_watched_is_warned_and_still_runs(cli, store, budget, warnings):
    result = cli("expert", "train", "InvertedPendulum-v5", *budget, *TINY_TD3)
    assert result.exit_code == 0, result.output
    shown = [line for line in result.output.splitlines() if line.startswith("warning: ")]
    assert len(shown) == len(warnings) and all(line.startswith(f"warning: {w}") for line, w in zip(shown, warnings)), shown
    assert store.resolve("invertedpendulum-v5-expert", "policy").metrics["env_steps"] == int(budget[1])


def test_imitate_warns_of_a_budget_that_never_leaves_its_random_steps(cli, store):
    bundled, embedding, disc = tiny_chain(store)
    result = cli("imitate", "InvertedPendulum-v5", "--demos", bundled.name, "--embedding", embedding.name, "--disc", disc.name,
                 "--steps", "40", "--eval-every", "40", "--set", "td3.learning_starts=16", "--set", "update_every=20", *TINY_TD3)
    assert result.exit_code == 0, result.output
    assert [line for line in result.output.splitlines() if line.startswith("warning: ")] == [
        "warning: --steps 40 is at most td3.random_steps (10000): every action is uniformly random, the policy kept never "
        "acted (raise --steps or lower --set td3.random_steps=N)"]
    assert store.resolve("invertedpendulum-v5-lwail", "policy").metrics["env_steps"] == 40


def test_quickstart_ends_with_three_next_commands_that_run(cli, store):
    """quickstart itself takes minutes; its closing lines are next_steps(), run here on a tiny expert."""
    import shlex
    import subprocess
    import sys

    from lwail_cli.cli.result_commands import next_steps
    from lwail_cli.stages.quickstart import quickstart_configs

    assert cli("expert", "train", "InvertedPendulum-v5", "--steps", "60", "--eval-every", "60", "--set", "td3.learning_starts=16", *TINY_TD3).exit_code == 0
    policy = store.resolve("invertedpendulum-v5-expert", "policy")
    (_, curve), (_, python), (_, other_task) = next_steps(policy.ref, "InvertedPendulum-v5", store.root)

    program, *arguments = shlex.split(curve)
    shown = cli(*arguments)
    assert program == "lwail" and shown.exit_code == 0 and f"{policy.ref}:" in shown.output, shown.output
    program, flag, code = shlex.split(python)
    loaded = subprocess.run([sys.executable, flag, code], capture_output=True, text=True, check=True)
    assert program == "python" and loaded.stdout.strip() == f"Policy({policy.ref}, env=InvertedPendulum-v5)"
    program, *arguments = shlex.split(other_task)
    assert program == "lwail" and "quickstart" in arguments
    quickstart_configs(arguments[arguments.index("--env") + 1], [f"imitate:train.steps={arguments[arguments.index('--steps') + 1]}"])  # no error


def test_curve_draws_each_run_beside_its_own_curve_never_over_another(cli, store, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the folder a user runs lwail from keeps nothing
    for seed in ("0", "1"):  # two versions of one name, with different curves
        assert cli("expert", "train", "InvertedPendulum-v5", "--name", "p", "--seed", seed, "--steps", "60", "--eval-every", "30",
                   "--set", "td3.learning_starts=16", "--set", "td3.random_steps=20", *TINY_TD3).exit_code == 0
    first, second = (store.resolve(f"p@v{version}", "policy") for version in (1, 2))
    drawn = cli("curve", "p@v1")
    assert drawn.exit_code == 0 and drawn.output.splitlines()[-1] == f"wrote {first.path / 'curve.png'}"
    figure = (first.path / "curve.png").read_bytes()
    assert cli("curve", "p").output.splitlines()[-1] == f"wrote {second.path / 'curve.png'}"
    assert (first.path / "curve.png").read_bytes() == figure and (second.path / "curve.png").read_bytes() != figure
    assert cli("curve", "p@v1", "p@v2").output.splitlines()[-1] == f"wrote {first.path / 'curve+p_v2.png'}"
    assert cli("curve", "p", "--out", tmp_path / "mine.png").output.splitlines()[-1] == f"wrote {tmp_path / 'mine.png'}"
    assert sorted(path.name for path in tmp_path.iterdir() if path.suffix == ".png") == ["mine.png"]
    assert "0 damaged" in cli("verify").output  # a figure beside an artifact is outside its hash


def test_importing_the_same_demos_again_keeps_the_version_that_holds_them(cli, store, tmp_path):
    from conftest import committed_versions, write_states_npz

    first = cli("demos", "import", "InvertedPendulum-v5", "--bundled")
    assert first.exit_code == 0 and first.output.startswith("wrote demos/invertedpendulum-v5-bundled-demos@v1")
    again = cli("demos", "import", "InvertedPendulum-v5", "--bundled")
    kept = store.resolve("invertedpendulum-v5-bundled-demos", "demos")
    assert again.exit_code == 0 and again.output.startswith(f"already in the store: {kept.ref}  ({kept.path}) holds the same content")
    assert committed_versions(store) == [("demos", "invertedpendulum-v5-bundled-demos", [1])]
    # a file: the same file keeps its version, another file (then the first again) makes a new one
    for seed, version in ((0, 1), (0, 1), (1, 2), (0, 3)):
        write_states_npz(tmp_path / "demos.npz", episodes=2, obs_dim=4, seed=seed)
        assert cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "demos.npz", "--name", "mine").exit_code == 0
        assert store.resolve("mine", "demos").version == version


def test_long_stages_report_progress_smoothly_not_only_when_they_log(store):
    """The bars (with their rate and time left) move with the work: ICVF every step, not only at its log rows; an
    online TD3 run every 100 env steps at most, not only at evaluations or every 500."""
    import torch

    from lwail_cli import config as cfg
    from lwail_cli.stages import collect, embed, expert

    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=300), seed=0)
    reports = []
    icvf = cfg.ICVFConfig(steps=40, hidden=(8,), embedding_dim=4, batch_size=16, log_every=20)
    embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=torch.device("cpu"),
                on_progress=lambda step, shown: reports.append((step, set(shown))))
    assert [step for step, _ in reports] == list(range(1, 41))
    assert [step for step, shown in reports if shown == {"loss"}] == [20, 40]  # the loss with each logged row

    steps = []
    config = cfg.ExpertConfig(td3=cfg.TD3Config(hidden=(8,), batch_size=16, random_steps=20, learning_starts=16),
                              train=cfg.TrainConfig(steps=450, eval_every=450, eval_episodes=1))
    expert.train_expert(store, env_id="InvertedPendulum-v5", config=config, seed=0, device=torch.device("cpu"),
                        on_progress=lambda step, shown: steps.append(step))
    assert steps[-1] == 450 and max(b - a for a, b in zip([0, *steps], steps)) <= 100, steps


def test_show_explains_the_metrics_it_prints_and_docs_list_them_all(cli, store):
    import json
    from pathlib import Path

    import torch

    from lwail_cli import config as cfg
    from lwail_cli import glossary
    from lwail_cli.stages import collect, demos, embed

    bundled = demos.import_bundled_demos(store, env_id="InvertedPendulum-v5")
    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=300), seed=0)
    icvf = cfg.ICVFConfig(steps=4, hidden=(8,), embedding_dim=4, batch_size=16, log_every=4)
    embedding = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(icvf=icvf), seed=0, device=torch.device("cpu"),
                            demos_ref=bundled.ref)
    shown = cli("show", embedding.name)
    assert shown.exit_code == 0 and json.loads(shown.stdout) == embedding.manifest  # stdout stays the manifest alone
    probes = [metric for metric in embedding.metrics if metric.startswith("probe_")]
    assert {"probe_separation_auc", "probe_progress_spearman", "probe_separation_auc_raw"} <= set(probes)
    explained = " ".join(shown.stderr.split())
    assert all(f" {metric} " in explained for metric in probes)
    assert "separation AUC: how often a random-policy pair" in explained and "progress Spearman: rank correlation" in explained

    usage = (Path(__file__).parents[1] / "docs" / "usage.md").read_text()
    documented = usage[usage.index("## What the metrics mean"):]
    assert all(f"`{metric}`" in documented for metric in glossary.METRICS)


def test_the_glossary_explains_every_figure_a_manifest_or_a_learning_curve_records():
    from lwail_cli import glossary, learning_curve
    from lwail_cli.methods import METHODS

    recorded = [*learning_curve.TABLE, "probe_spearman_raw", "final_loss"]  # the curve's columns, φ's and f's metrics
    unexplained = [name for name in recorded if name not in glossary.SELF_EXPLAINED and glossary.meaning(name) is None]
    assert unexplained == []
    assert "cross-entropy" in glossary.meaning("discriminator_loss") and "target network" in glossary.meaning("target_normalized_score")
    assert all(method.reward in glossary.meaning("reward_expert_mean") for method in METHODS.values())


def test_the_python_example_of_the_docs_runs_on_a_quickstart_store(tmp_path, monkeypatch, capsys):
    """docs/usage.md#python, run as written from a folder whose ./artifacts holds what quickstart names (tiny budgets)."""
    from pathlib import Path

    import torch

    from lwail_cli import config as cfg
    from lwail_cli.artifacts import Store
    from lwail_cli.stages import imitate

    monkeypatch.delenv("LWAIL_STORE", raising=False)
    monkeypatch.chdir(tmp_path)
    store = Store("artifacts")
    bundled, embedding, disc = tiny_chain(store)
    config = cfg.ImitationConfig(td3=cfg.TD3Config(hidden=(8,), batch_size=16, random_steps=20, learning_starts=16),
                                 train=cfg.TrainConfig(steps=60, eval_every=60, eval_episodes=1), update_every=30, update_steps=1)
    imitate.imitate(store, env_id="InvertedPendulum-v5", demos_ref=bundled.ref, embedding_ref=embedding.ref, disc_ref=disc.ref,
                    config=config, seed=0, device=torch.device("cpu"))

    usage = (Path(__file__).parents[1] / "docs" / "usage.md").read_text()
    section = usage[usage.index("\n## Python\n"):]
    start = section.index("```python\n") + len("```python\n")
    code = section[start:section.index("\n```", start)]
    assert 'store="artifacts"' in code.replace(" ", "") and "load_policy(" in code and "load_reward(" in code
    exec(compile(code, "docs/usage.md#python", "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith("Policy(policy/invertedpendulum-v5-lwail@v1, env=InvertedPendulum-v5): return ")
    assert printed[1].startswith("(100, 4) ")
