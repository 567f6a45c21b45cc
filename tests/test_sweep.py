"""`lwail sweep` and `lwail report`: plans checked before anything runs; the smoke plan end to end on local Ray."""

import shutil
from pathlib import Path

import pandas as pd
import pytest

from conftest import committed_versions

PLANS = Path(__file__).resolve().parents[1] / "plans"
VARIANT_PLAN = '''name = "x"
tasks = ["InvertedPendulum-v5"]
seeds = [0]
embeddings = ["icvf", "jax-phi"]
[variants.jax-phi]
kind = "icvf"
pretrain-icvf = ["icvf.layer_norm=after"]
'''


@pytest.mark.parametrize(
    "text, message",
    [
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nsteps = 5', "unknown keys ['steps']"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0, 0]', "'seeds' must be a non-empty list of distinct integers"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [-1]', "'seeds' must be a non-empty list of distinct integers"),
        ('name = "x"\ntasks = ["Swimmer-v5"]\nseeds = [0]', "no bundled demos for Swimmer-v5"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nembeddings = ["pca"]', "unknown embedding 'pca' in 'embeddings'; arms (embedding kinds and [variants]): curl, icvf, identity, infonce"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nembeddings = ["icvff"]', "unknown embedding 'icvff' in 'embeddings'; did you mean icvf?"),
        (VARIANT_PLAN.replace('"icvf", "jax-phi"', '"icvf", "jax-phy"'), "unknown embedding 'jax-phy' in 'embeddings'; did you mean jax-phi?"),
        ('name = "x"\ntasks = ["Hoper-v5"]\nseeds = [0]', "no bundled demos for Hoper-v5; did you mean Hopper-v5?"),
        ('name = "../x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]', "artifact name '../x'"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[set]\nimitate = ["td3.gamma=1.5"]', "gamma"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[set]\npretrain-icvf = ["kind=identity"]', "comes from 'embeddings'"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[set]\ntrain = ["steps=1"]', "[set] may hold lists"),
        ('name = "x"\ntasks = [', "is not valid TOML"),
        (VARIANT_PLAN.replace('[variants.jax-phi]', '[variants.icvf]'), "would shadow the embedding kind icvf"),
        (VARIANT_PLAN.replace('kind = "icvf"', 'kind = "pca"'), "needs kind = one of ['icvf', 'identity', 'infonce', 'curl']"),
        (VARIANT_PLAN + 'collect = ["transitions=5"]', "[variants.jax-phi] may hold lists of field=value for the stages ['pretrain-icvf'"),
        (VARIANT_PLAN.replace('"icvf.layer_norm=after"', '"kind=identity"'), "the embedding kind comes from 'embeddings'"),
        (VARIANT_PLAN.replace('"icvf.layer_norm=after"', '"icvf.ensemble=maybe"'), "--set icvf.ensemble: cannot read 'maybe'"),
        (VARIANT_PLAN.replace('"icvf", "jax-phi"', '"icvf"'), "[variants] jax-phi defined but not listed in 'embeddings'"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nalso = 5', "'also' must be [[also]] tables"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[[also]]\ntasks = ["InvertedPendulum-v5"]\nseeds = [1]\nthreads = 2',
         "[[also]] table 1: unknown keys ['threads']"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[[also]]\ntasks = ["InvertedPendulum-v5"]\nseeds = [1]\nembeddings = ["pca"]',
         "[[also]] table 1: unknown embedding 'pca'"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[[also]]\ntasks = ["Swimmer-v5"]\nseeds = [1]', "no bundled demos for Swimmer-v5"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nthreads = 0', "'threads' must be an integer from 1 to 256"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nthreads = "2"', "'threads' must be an integer from 1 to 256"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nthreads = 256', "the plan gives each run 256 threads; this machine has"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nmethods = ["bc"]', "unknown method 'bc' in 'methods'; the registered methods: lwail, gaifo, pwil"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\nmethods = ["gaifo", "gaifo"]', "'methods' must be a non-empty list of distinct methods"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[set]\nimitate = ["method=pwil"]', "[set]: the method comes from 'methods', not from imitate"),
        ('name = "x"\ntasks = ["InvertedPendulum-v5"]\nseeds = [0]\n[axis]\nsetting = "method"\nvalues = ["pwil"]', "[axis]: 'method' comes from the grid"),
    ],
)
def test_a_bad_plan_is_one_clear_line_before_anything_runs(cli, store, tmp_path, text, message):
    plan = tmp_path / "plan.toml"
    plan.write_text(text)
    result = cli("sweep", plan)
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert committed_versions(store) == []


def test_without_ray_the_sweep_says_how_to_install_it(cli, store, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    result = cli("sweep", PLANS / "smoke.toml")
    assert result.exit_code == 1 and 'pip install "lwail[sweep]"' in result.output


def test_a_private_ray_runs_the_sweeps_workers_at_the_drivers_priority(monkeypatch):
    from lwail_cli.stages.sweep import start_ray

    ray = pytest.importorskip("ray")
    monkeypatch.delenv("RAY_worker_niceness", raising=False)  # Ray's own default: 15 steps nicer than the driver

    def niceness() -> int:  # nested, so Ray ships it by value (a worker cannot import this test module)
        import os

        return os.nice(0)

    start_ray(ray, None)
    try:
        assert ray.get(ray.remote(num_cpus=0)(niceness).remote()) == niceness()
    finally:
        ray.shutdown()


def test_smoke_sweep_shares_stages_restarts_without_redoing_them_and_reports(cli, store, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:9")  # a cluster named elsewhere on this machine is not this sweep's
    result = cli("sweep", PLANS / "smoke.toml")
    assert result.exit_code == 0, result.output
    versions = {(kind, name): v for kind, name, v in committed_versions(store)}
    kinds = [kind for kind, _ in versions]
    # one demos per task, one data set per seed shared by both embeddings, then one chain per run
    assert [kinds.count(k) for k in ("demos", "dataset", "embedding", "discriminator", "policy", "report")] == [1, 3, 6, 6, 6, 1]
    report = store.resolve("smoke", "report")
    summary = pd.read_csv(report.file("summary.csv"))
    assert sorted(summary["arm"]) == ["icvf", "identity"] and (summary["seeds"] == 3).all()
    runs = pd.read_csv(report.file("runs.csv"))
    assert len(runs) == 6 and runs["at_end"].notna().all() and (runs["env_steps"] == 600).all()
    assert (runs["expert_return"] == 1000.0).all() and runs["at_end_expert_pct"].between(0, 100).all()  # the bundled 1,000
    for figure in ("invertedpendulum-v5_curves.png", "invertedpendulum-v5_critic.png", "profile.png"):
        assert report.file(figure).is_file()
    assert "| InvertedPendulum-v5 | icvf |" in result.output

    # a restart after one policy was lost redoes that imitation only
    lost = store.resolve("smoke-invertedpendulum-v5-s1-icvf", "policy")
    shutil.rmtree(lost.path.parent)
    assert cli("sweep", PLANS / "smoke.toml").exit_code == 0
    again = {(kind, name): v for kind, name, v in committed_versions(store)}
    assert again.pop(("report", "smoke")) == [1, 2]  # a report per sweep
    versions.pop(("report", "smoke"))
    assert again == versions

    rebuilt = cli("report", "smoke")
    assert rebuilt.exit_code == 0 and "| InvertedPendulum-v5 | identity |" in rebuilt.output


@pytest.mark.parametrize("plan", sorted(PLANS.glob("*.toml")), ids=lambda path: path.name)
def test_the_shipped_plans_are_valid(plan):
    from lwail_cli.stages.sweep_plan import read_plan

    assert read_plan(plan).runs  # every task has bundled demos, every override is a valid setting


def test_an_also_grid_adds_runs_after_the_plans_own_grid_each_run_once():
    import tomllib

    from lwail_cli.stages.sweep_plan import SweepRun, plan_from_dict

    raw = tomllib.loads(VARIANT_PLAN.replace('"icvf", "jax-phi"', '"icvf", "identity"') + """
[[also]]
tasks = ["InvertedPendulum-v5", "Hopper-v5"]
seeds = [1]
embeddings = ["identity", "jax-phi"]
[[also]]
tasks = ["InvertedPendulum-v5"]
seeds = [0, 1]
embeddings = ["identity"]
""")
    plan = plan_from_dict(raw, "test plan")
    pendulum, hopper = "InvertedPendulum-v5", "Hopper-v5"
    assert plan.runs == [SweepRun(pendulum, 0, "icvf"), SweepRun(pendulum, 0, "identity"),
                         SweepRun(pendulum, 1, "identity"), SweepRun(pendulum, 1, "jax-phi"),
                         SweepRun(hopper, 1, "identity"), SweepRun(hopper, 1, "jax-phi")]  # the last grid adds nothing new
    assert plan.tasks == [pendulum, hopper] and plan.kinds == ["icvf", "identity", "jax-phi"]
    assert plan.data_sets == [(pendulum, 0), (pendulum, 1), (hopper, 1)]  # no Hopper seed 0: no run of it needs one
    assert plan.config("pretrain-icvf", "jax-phi").icvf.layer_norm == "after"  # a variant listed only in [[also]] is used
    assert plan.names(SweepRun(hopper, 1, "jax-phi"))["policy"] == "x-hopper-v5-s1-jax-phi"
    assert plan_from_dict(plan.to_dict(), "a report's record") == plan
    assert "also" not in plan_from_dict(tomllib.loads(VARIANT_PLAN), "test plan").to_dict()  # a plain plan records what it did


# each shipped plan's runs as 45caa73 (before plans named methods) recorded them, less the settings a run does not read
# (other methods' and embedding kinds' sections: settings.section's used_when): every artifact name and stage config.
# pointmaze-noise's noise arms now read one φ per embedding kind (SweepPlan.phi_of): its hash with the φ names each arm
# had before (<arm>) is 45caa73's, 70cbe3ed1c58cb2e; nothing else changed
FINGERPRINTS = {
    "halfcheetah-diagnose.toml": "2954a2c589f5890a", "halfcheetah-screen-protect.toml": "d4aad4fc9cdbfde1",
    "halfcheetah-screen.toml": "f0e0e92c3ad2deca", "hopper-1m-identity.toml": "69359d4bedb4e1bd", "hopper-1m-target.toml": "ec6edde7c2ba9985",
    "hopper-300k.toml": "af7d6c1807922752", "mujoco-table.toml": "0f72a80faf874dc9", "paper-table.toml": "e1fafc1464e53e82",
    "paper.toml": "1f4f6a9da7bd33d6", "pointmaze-noise.toml": "30f871ba00deae65", "smoke.toml": "3b8a39f3f374f11e",
}


@pytest.mark.parametrize("plan", sorted(FINGERPRINTS))
def test_a_plan_without_methods_names_and_configures_its_runs_as_before(plan):
    """What the sweep's ledger fingerprints (each artifact's name, its stage's config, the seed) and what a report
    records are those of the plan before `methods` existed: a restarted sweep finds its finished stages."""
    import hashlib
    import json

    from lwail_cli import config as cfg
    from lwail_cli.stages.declaration import PLAN_STAGES
    from lwail_cli.stages.sweep_plan import read_plan

    read = read_plan(PLANS / plan)
    rows = [[read.names(run), {stage: cfg.to_dict(read.run_config(stage, run)) for stage in PLAN_STAGES}, run.seed, run.task]
            for run in read.runs]
    assert hashlib.sha256(json.dumps(rows, sort_keys=True).encode()).hexdigest()[:16] == FINGERPRINTS[plan]
    assert read.methods == ["lwail"] and "methods" not in json.dumps(read.to_dict())


def test_the_methods_of_an_arm_share_its_data_and_phi_and_only_lwail_warms_up(store):
    import tomllib

    import torch

    from lwail_cli.stages.sweep import bundled_demos, collect_task, embed_task, run_task
    from lwail_cli.stages.sweep_plan import SweepRun, grid_lines, plan_from_dict

    raw = tomllib.loads((PLANS / "smoke.toml").read_text())
    raw.update(name="m", seeds=[0], embeddings=["icvf"], methods=["lwail", "pwil"])
    plan = plan_from_dict(raw, "test plan")
    task = "InvertedPendulum-v5"
    assert plan.runs == [SweepRun(task, 0, "icvf", "lwail"), SweepRun(task, 0, "icvf", "pwil")]
    assert [plan.names(run)["policy"] for run in plan.runs] == ["m-invertedpendulum-v5-s0-icvf-lwail", "m-invertedpendulum-v5-s0-icvf-pwil"]
    assert grid_lines(plan)[-2:] == [f"{task} seed 0 icvf-lwail (icvf, lwail)", f"{task} seed 0 icvf-pwil (icvf, pwil)"]
    assert plan_from_dict(plan.to_dict(), "a report's record") == plan
    threads = torch.get_num_threads()
    try:  # the Ray tasks' bodies, in this process
        demos = bundled_demos(store, plan, task).ref
        data = collect_task(str(store.root), plan.to_dict(), task, 0)
        phi = embed_task(str(store.root), plan.to_dict(), task, 0, "icvf", demos, data)
        assert embed_task(str(store.root), plan.to_dict(), task, 0, "icvf", demos, data) == phi  # the ledger's, not trained again
        results = [run_task(str(store.root), plan.to_dict(), task, 0, "icvf", demos, data, run.method, phi) for run in plan.runs]
    finally:
        torch.set_num_threads(threads)
    kinds = [kind for kind, *_ in committed_versions(store)]
    assert [kinds.count(kind) for kind in ("dataset", "embedding", "discriminator", "policy")] == [1, 1, 1, 2]
    policies = [store.resolve(result["policy"], "policy") for result in results]
    assert [policy.config["method"] for policy in policies] == ["lwail", "pwil"]
    assert {store.resolve_parent(policy, "embedding").ref for policy in policies} == {phi}


def test_a_variant_is_one_more_arm_with_its_own_overrides_and_shares_the_seeds_data(store, monkeypatch):
    import tomllib

    import torch

    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep import _live_status, bundled_demos, collect_task, run_task
    from lwail_cli.stages.sweep_plan import plan_from_dict

    raw = tomllib.loads((PLANS / "smoke.toml").read_text())
    raw.update(name="ab", seeds=[0], embeddings=["icvf", "jax-phi"],
               variants={"jax-phi": {"kind": "icvf", "pretrain-icvf": ["icvf.layer_norm=after"], "imitate": ["td3.gamma=0.9"]}})
    raw["set"]["pretrain-icvf"] = [*raw["set"]["pretrain-icvf"], "icvf.layer_norm=none"]  # the arm icvf: the authors' φ
    plan = plan_from_dict(raw, "test plan")
    assert [run.kind for run in plan.runs] == ["icvf", "jax-phi"]
    assert plan_from_dict(plan.to_dict(), "a report's record") == plan  # a report rebuilds the same plan

    shown = []  # what the driver shows of the first run as each of its stages starts, collect's included

    def watched(stage):
        def call(*args, **kwargs):
            shown.append(_live_status(store, plan, plan.runs[0]))
            return stage(*args, **kwargs)
        return call

    for stage in ("run_stage", "evaluate"):  # the chain's stages (collect, pretrain-icvf, warmup-disc, imitate) and eval
        monkeypatch.setattr(sweep, stage, watched(getattr(sweep, stage)))
    threads = torch.get_num_threads()
    try:  # the Ray tasks' bodies, in this process
        demos = bundled_demos(store, plan, "InvertedPendulum-v5").ref
        data = collect_task(str(store.root), plan.to_dict(), "InvertedPendulum-v5", 0)
        assert _live_status(store, plan, plan.runs[0]) is None  # shown as queued
        results = {kind: run_task(str(store.root), plan.to_dict(), "InvertedPendulum-v5", 0, kind, demos, data) for kind in plan.kinds}
    finally:
        torch.set_num_threads(threads)
    assert shown[:5] == ["collecting data set I", "pre-training φ", "warming up f", "imitating: before the first evaluation", "evaluating"]
    assert _live_status(store, plan, plan.runs[0]) is None  # done: the driver has it from Ray
    embeddings = {kind: store.resolve(f"ab-invertedpendulum-v5-s0-{kind}", "embedding") for kind in plan.kinds}
    planned = {kind: plan.config("pretrain-icvf", kind).icvf.layer_norm for kind in plan.kinds}
    assert {kind: e.config["icvf"]["layer_norm"] for kind, e in embeddings.items()} == planned and len(set(planned.values())) == 2
    assert {e.config["type"] for e in embeddings.values()} == {"icvf"}
    policies = {kind: store.resolve(results[kind]["policy"], "policy") for kind in plan.kinds}
    assert {kind: p.config["td3"]["gamma"] for kind, p in policies.items()} == {"icvf": 0.99, "jax-phi": 0.9}
    assert {p.config["train"]["steps"] for p in policies.values()} == {600}  # the plan's [set] reaches every arm
    assert [kind for kind, *_ in committed_versions(store)].count("dataset") == 1  # one data set I for both arms
    store.runs.set_sweep_status(plan.name, plan.names(plan.runs[1])["policy"], "imitating")  # as a run that imitates says
    assert _live_status(store, plan, plan.runs[1]).startswith("imitating: step 600 of 600, normalized score ")

    # a restart takes every finished stage from the ledger, the closing evaluation included
    evals = policies["icvf"].file("evals.csv")
    rows = evals.read_text()
    try:
        again = run_task(str(store.root), plan.to_dict(), "InvertedPendulum-v5", 0, "icvf", demos, data)
    finally:
        torch.set_num_threads(threads)
    assert again == results["icvf"] and evals.read_text() == rows


def test_the_papers_figure_is_looked_up_by_task_and_embedding_kind():
    from lwail_cli.evaluation import paper_score

    assert paper_score("AntNoContactForces-v5", "identity") == (40.72, 18.95) and paper_score("InvertedPendulum-v5", "icvf") is None
    assert paper_score("Walker2d-v5", "icvf") == (106.51, 1.14)


def test_a_restarted_sweep_imports_a_retrained_bundle_as_a_new_version(store, tmp_path, monkeypatch):
    import tomllib

    import numpy as np

    from lwail_cli.stages import demos
    from lwail_cli.stages.sweep import bundled_demos
    from lwail_cli.stages.sweep_plan import plan_from_dict

    plan = plan_from_dict(tomllib.loads((PLANS / "smoke.toml").read_text()), "test plan")
    first = bundled_demos(store, plan, "InvertedPendulum-v5")
    assert bundled_demos(store, plan, "InvertedPendulum-v5").ref == first.ref  # the same bundle: taken from the ledger

    with np.load(demos.bundled_demos_path("InvertedPendulum-v5")) as shipped:  # a retrained expert's bundle
        arrays = {key: shipped[key] for key in shipped.files}
    arrays["observations"] = arrays["observations"] + 0.5
    retrained = tmp_path / "InvertedPendulum-v5.npz"
    np.savez(retrained, **arrays)
    monkeypatch.setattr(demos, "bundled_demos_path", lambda env_id: retrained)
    second = bundled_demos(store, plan, "InvertedPendulum-v5")
    assert second.version == first.version + 1 and second.hash != first.hash
    assert bundled_demos(store, plan, "InvertedPendulum-v5").ref == second.ref


def test_a_queued_run_with_a_checkpoint_says_how_far_its_imitation_got(store):
    import tomllib

    from lwail_cli.stages.sweep import _live_status
    from lwail_cli.stages.sweep_plan import plan_from_dict

    plan = plan_from_dict(tomllib.loads((PLANS / "smoke.toml").read_text()), "test plan")
    run, other = plan.runs[0], plan.runs[1]
    name = plan.names(run)["policy"]
    store.runs.save_checkpoint("policy", name, {"step": 50})  # as a killed sweep leaves it
    assert _live_status(store, plan, run) == "queued, its imitation checkpointed"
    store.runs.write_run_log("policy", name, "learning_curve.csv", [{"step": 40, "return_mean": 1.0}, {"step": 60, "return_mean": 2.0}])
    assert _live_status(store, plan, run) == "queued, its imitation checkpointed (curve to step 60)"
    assert _live_status(store, plan, other) is None  # no checkpoint: plainly queued


def test_an_imitating_run_says_its_pace_and_the_time_left(store):
    import tomllib

    from lwail_cli.stages.sweep import _live_status
    from lwail_cli.stages.sweep_plan import plan_from_dict

    raw = tomllib.loads((PLANS / "smoke.toml").read_text())
    raw["set"]["imitate"] = ["train.steps=1000000"]
    plan = plan_from_dict(raw, "test plan")
    run = plan.runs[0]
    name = plan.names(run)["policy"]
    store.runs.set_sweep_status(plan.name, name, "imitating")
    rows = [{"step": 10_000, "wall_time": 50.0, "return_mean": 30.0, "normalized_score": 3.0}]
    store.runs.write_run_log("policy", name, "learning_curve.csv", rows)
    assert _live_status(store, plan, run) == "imitating: step 10000 of 1000000, normalized score 3.0"  # no pace from one evaluation
    rows += [{"step": 10_000 * i, "wall_time": 50.0 + 100.0 * (i - 1), "return_mean": 10.0 * i, "normalized_score": float(i)} for i in range(2, 11)]
    store.runs.write_run_log("policy", name, "learning_curve.csv", rows)
    # the last 6 evaluations: 50k steps in 500 s, 100 env-steps/s; 900k steps to go take 2.5 h
    assert _live_status(store, plan, run) == "imitating: step 100000 of 1000000, normalized score 10.0, 100 env-steps/s, ~2.5 h to go"


def _fake_ray(monkeypatch, at_once: int, on_wait=lambda: None, get=lambda task: {"normalized_score": 1.0}) -> list:
    """Ray as the driver sees it on 2 CPUs: a run's or φ's task finishes when the driver next waits (``on_wait()`` is
    called first), first started first finished, and never more than ``at_once`` work at once; ``get`` gives a task's
    result. Returns what was handed to Ray: (function, args, task)."""
    import sys
    import types

    from lwail_cli.stages import sweep

    handed, working = [], []  # working: the runs and φs at work, oldest first

    def remote(num_cpus, max_retries=3):
        def wrap(function):
            def submit(*args):
                task = object()
                handed.append((function, args, task))
                if function in (sweep.run_task, sweep.embed_task):
                    working.append(task)
                    assert len(working) <= at_once, f"{len(working)} runs and φs handed to Ray at once on 2 CPUs"
                return task
            return types.SimpleNamespace(remote=submit)
        return wrap

    def wait(tasks, num_returns, timeout):
        on_wait()
        oldest = next(task for task in working if task in tasks)
        working.remove(oldest)
        return [oldest], [task for task in tasks if task is not oldest]

    fake_ray = types.SimpleNamespace(init=lambda **kwargs: None, shutdown=lambda: None, remote=remote, wait=wait,
                                     cluster_resources=lambda: {"CPU": 2.0}, get=get)
    monkeypatch.setitem(sys.modules, "ray", fake_ray)
    monkeypatch.setattr(sweep.os, "cpu_count", lambda: 2)
    return handed


@pytest.mark.parametrize("threads, at_once", [(1, 2), (2, 1)])
def test_runs_start_in_the_plans_order_never_more_at_once_than_the_cpus_hold(store, monkeypatch, threads, at_once):
    import tomllib

    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep_plan import plan_from_dict

    raw = tomllib.loads((PLANS / "smoke.toml").read_text()) | {"threads": threads}
    plan = plan_from_dict(raw, "test plan")
    handed = _fake_ray(monkeypatch, at_once)
    assert sweep.run_sweep(store, plan=plan, poll_seconds=0) == []
    started = [args[2:5] for function, args, _ in handed if function is sweep.run_task]
    assert started == [(run.task, run.seed, run.kind) for run in plan.runs] and len(started) == 6


@pytest.mark.parametrize("signum", ["SIGTERM", "SIGINT"])
def test_a_signalled_sweep_pauses_what_is_at_work_starts_nothing_more_and_says_how_to_go_on(store, monkeypatch, signum):
    import os
    import signal

    from lwail_cli.errors import LwailError, RunPaused
    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep_plan import read_plan

    plan = read_plan(PLANS / "smoke.toml")
    signalled, asked = [], []
    handed: list = []

    def signal_at_the_third_wait():
        if len(signalled) == 2:
            os.kill(os.getpid(), getattr(signal, signum))  # as `kill` or Ctrl-C would, while the driver waits on Ray
        signalled.append(len(handed))

    class TaskError(Exception):  # Ray's error for a task that raised: the task's exception is its cause
        def __init__(self, cause):
            self.cause = cause

    def result(task):
        if len(signalled) > 2:  # finished after the signal: it was asked to pause
            raise TaskError(RunPaused(1200))
        return {"normalized_score": 1.0}

    monkeypatch.setattr(type(store.runs), "request_pause", lambda runs, name, missing_ok=False: asked.append((name, missing_ok)) or [])
    handed += _fake_ray(monkeypatch, at_once=2, on_wait=signal_at_the_third_wait, get=result)
    before = {each: signal.getsignal(each) for each in (signal.SIGTERM, signal.SIGINT)}
    with pytest.raises(LwailError, match=r"the sweep stopped as asked; paused with their checkpoints kept: .* at step 1200.*; "
                                         r"failed: 0; the rest not started\. Run the same sweep again to continue"):
        sweep.run_sweep(store, plan=plan, poll_seconds=0)
    work = [(function, args) for function, args, _ in handed if function in (sweep.run_task, sweep.embed_task)]
    assert len(handed) == signalled[2] and len(work) < len(plan.runs) + len(plan.phis)  # nothing handed out after the signal
    at_work = {plan.names(run)["policy"] for run in plan.runs} | {plan.phi_name(*phi) for phi in plan.phis}
    assert asked and {name for name, _ in asked} <= at_work and all(missing_ok for _, missing_ok in asked)
    assert {each: signal.getsignal(each) for each in before} == before  # the driver's handlers are gone with it


def test_the_arms_of_an_axis_that_does_not_reach_phi_imitate_on_one_phi_made_once(store, monkeypatch):
    """The noise table's arms differ only in the imitation's start-state noise: per embedding kind one φ is trained,
    named after the first arm, and its three runs are handed that φ."""
    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep_plan import read_plan

    plan = read_plan(PLANS / "pointmaze-noise.toml")
    task = "PointMazeMedium-v0"
    assert plan.phis == [(task, 0, "icvf-noise0.0"), (task, 0, "identity-noise0.0")]
    assert {plan.names(run)["embedding"] for run in plan.runs if plan.embedding_kind(run.kind) == "icvf"} == {"pointmaze-noise-pointmazemedium-v0-s0-icvf-noise0.0"}
    handed = _fake_ray(monkeypatch, at_once=2)
    assert sweep.run_sweep(store, plan=plan, poll_seconds=0) == []
    phis = {args[4]: phi for function, args, phi in handed if function is sweep.embed_task}
    assert list(phis) == ["icvf-noise0.0", "identity-noise0.0"]
    runs = {args[4]: args[-1] for function, args, _ in handed if function is sweep.run_task}  # each run's arm -> the φ it was handed
    assert runs == {f"{kind}-noise{noise}": phis[f"{kind}-noise0.0"] for kind in ("icvf", "identity") for noise in ("0.0", "0.2", "0.5")}


def test_the_queue_trains_an_arms_phi_on_one_core_while_the_other_works_and_hands_runs_out_in_the_plans_order():
    from lwail_cli.stages.sweep_queue import RunQueue
    from lwail_cli.stages.sweep_plan import SweepRun

    task = "Hopper-v5"
    plan = [SweepRun(task, 0, kind, method) for kind in ("icvf", "identity") for method in ("lwail", "gaifo", "pwil")]
    queue = RunQueue(list(plan), places=2)
    # both places train a φ (the old driver gave both to the first arm's runs, which waited on one φ: a core idle)
    assert queue.take() == ([(task, 0, "icvf"), (task, 0, "identity")], [])
    queue.phi_made((task, 0, "icvf"))
    assert queue.take() == ([], plan[:1])  # one place freed: the first run of the arm whose φ is made
    queue.phi_made((task, 0, "identity"))
    assert queue.take() == ([], plan[1:2])  # then the plan's order, not the arm that finished last
    queue.run_ended()
    assert queue.take() == ([], plan[2:3])
    queue.run_ended(), queue.run_ended()
    assert queue.take() == ([], plan[3:5])
    while queue.unfinished():
        queue.run_ended()
        assert queue.busy() <= 2
        queue.take()
    assert queue.running == 0 and not queue.parked and not queue.waiting


@pytest.mark.parametrize("places", [1, 2, 3])
def test_the_queue_never_leaves_a_place_free_while_work_waits_and_runs_each_once(places):
    """A simulated sweep (a φ takes 3 ticks, a run 7): every run handed out once, in the plan's order, never more than
    ``places`` at work, and a place is free only when nothing could start."""
    from lwail_cli.stages.sweep_queue import RunQueue, arm_of
    from lwail_cli.stages.sweep_plan import SweepRun

    plan = [SweepRun(task, seed, kind, method) for task in ("Hopper-v5", "Walker2d-v5") for seed in (0, 1)
            for kind in ("icvf", "identity") for method in ("lwail", "pwil")]
    queue, handed, work = RunQueue(list(plan), places=places), [], {}  # work: what is being done -> ticks left
    while queue.unfinished():
        phis, runs = queue.take()
        work |= {("phi", arm): 3 for arm in phis} | {("run", run): 7 for run in runs}
        handed += runs
        assert len(work) == queue.busy() <= places
        startable = queue.waiting or any(arm_of(run) in queue.made for run in queue.parked)
        assert len(work) == places or not startable
        for item in [item for item in work if work[item] == 1]:
            del work[item]
            queue.phi_made(item[1]) if item[0] == "phi" else queue.run_ended()
        work = {item: ticks - 1 for item, ticks in work.items()}
    assert handed == plan


def test_a_run_that_lwail_0_3_finished_is_found_under_its_0_3_fingerprint_and_not_run_again(store, monkeypatch):
    """The 3-seed table's HalfCheetah seed 2 finished on lwail 0.3 (45caa73), whose ledger fingerprinted every section
    of the config, read or not; today's records leave unread ones out. Its ledger entry, as 0.3 wrote it (the key and the
    parents' hashes are that store's), still names the finished run, which is then filed under today's fingerprint."""
    from types import SimpleNamespace

    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep_plan import read_plan

    plan = read_plan(PLANS / "mujoco-table.toml")
    run = next(run for run in plan.runs if (run.task, run.seed, run.kind) == ("HalfCheetah-v5", 2, "icvf"))
    name = plan.names(run)["policy"]
    assert name == "mujoco-table-halfcheetah-v5-s2-icvf"
    with store.create("policy", name, env=None, config={}, seed=2) as writer:
        (writer.path("learning_curve.csv")).write_text("step\n1000000\n")
    finished = writer.artifact
    store.runs.record_finished_stage(plan.name, "400c9f42a1dc9ead063ace9712bcf5d2", finished.ref)  # 0.3's entry
    parents = {"demos": "fc6ed6601605ba2e85d741659fc154d1373ddc36499e122acce0a9a94746e02c",
               "embedding": "bc26342af1cdaccb74a2c031261fcb7bdb5e1df9279b36393e16ec58083c9427",
               "discriminator": "9114d5b9f096518fe12364910388ac0a15b499481c2aa67e4e76383552776ec7"}
    made = {kind: SimpleNamespace(hash=digest) for kind, digest in parents.items()}

    def run_again(*args, **kwargs):
        raise AssertionError("a finished run ran again")

    monkeypatch.setattr(sweep, "run_stage", run_again)
    assert sweep._stage(store, plan, run, "imitate", made).ref == finished.ref
    entries = sorted(path.stem for path in (store.root / ".runs" / "sweep" / plan.name).glob("*.ref"))
    assert len(entries) == 2 and "400c9f42a1dc9ead063ace9712bcf5d2" in entries
    (store.root / ".runs" / "sweep" / plan.name / "400c9f42a1dc9ead063ace9712bcf5d2.ref").unlink()
    assert sweep._stage(store, plan, run, "imitate", made).ref == finished.ref  # today's entry alone finds it now
    with pytest.raises(AssertionError, match="ran again"):  # another run (seed 1's parents) is not this one
        sweep._stage(store, plan, run, "imitate", {**made, "demos": SimpleNamespace(hash="0" * 64)})


def test_only_picks_runs_by_task_seed_and_arm_in_the_plans_order():
    from lwail_cli.stages.sweep_plan import SweepRun, read_plan, select_runs

    plan = read_plan(PLANS / "mujoco-table.toml")
    assert select_runs(plan, []) == plan.runs and len(plan.runs) == 24
    assert select_runs(plan, ["Walker2d-v5:0"]) == [SweepRun("Walker2d-v5", 0, "icvf"), SweepRun("Walker2d-v5", 0, "identity")]
    assert select_runs(plan, ["Walker2d-v5:*:identity"]) == [SweepRun("Walker2d-v5", seed, "identity") for seed in (0, 1, 2)]
    # several selectors: their union, each run once, in the plan's order (the default's runs before the identity's)
    union = select_runs(plan, ["*:1:identity", "Hopper-v5:1", "AntNoContactForces-v5"])
    assert union == ([SweepRun("Hopper-v5", 1, "icvf")] + [SweepRun("AntNoContactForces-v5", seed, "icvf") for seed in (0, 1, 2)]
                     + [SweepRun(task, 1, "identity") for task in ("HalfCheetah-v5", "Hopper-v5", "Walker2d-v5")]
                     + [SweepRun("AntNoContactForces-v5", seed, "identity") for seed in (0, 1, 2)])


@pytest.mark.parametrize("selector, message", [
    ("Walker2d:0", "--only 'Walker2d:0': the plan has no task 'Walker2d'; its tasks: HalfCheetah-v5, Hopper-v5, Walker2d-v5, AntNoContactForces-v5"),
    ("Hopper-v5:7", "--only 'Hopper-v5:7': the plan has no seed '7'; its seeds: 0, 1, 2"),
    ("*:0:infonce", "--only '*:0:infonce': the plan has no arm 'infonce'; its arms: icvf, identity"),
    ("Hopper-v5::icvf", "--only 'Hopper-v5::icvf': give TASK[:SEED[:ARM]]"),
])
def test_a_bad_only_is_one_clear_line_before_anything_runs(cli, store, selector, message):
    result = cli("sweep", PLANS / "mujoco-table.toml", "--only", selector)
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert not committed_versions(store)


def test_an_only_sweep_runs_and_collects_for_the_picked_runs_alone_and_dry_run_lists_them(cli, store, monkeypatch):
    import tomllib

    from lwail_cli.stages import sweep
    from lwail_cli.stages.sweep_plan import plan_from_dict, select_runs

    plan = plan_from_dict(tomllib.loads((PLANS / "smoke.toml").read_text()), "test plan")
    picked = select_runs(plan, ["InvertedPendulum-v5:2:identity", "*:1:icvf"])
    handed = _fake_ray(monkeypatch, at_once=2)
    assert sweep.run_sweep(store, plan=plan, runs=picked, poll_seconds=0) == []
    assert [args[2:5] for function, args, _ in handed if function is sweep.run_task] == [
        ("InvertedPendulum-v5", 1, "icvf"), ("InvertedPendulum-v5", 2, "identity")]
    assert [args[2:4] for function, args, _ in handed if function is sweep.collect_task] == [("InvertedPendulum-v5", 1), ("InvertedPendulum-v5", 2)]
    listed = cli("sweep", PLANS / "smoke.toml", "--dry-run", "--only", "*:1:icvf")
    assert listed.exit_code == 0 and "1 of 6 runs on 1 data sets I and 1 φs" in listed.output, listed.output
    assert "InvertedPendulum-v5 seed 1 icvf (icvf, lwail)" in listed.output and "seed 0" not in listed.output
