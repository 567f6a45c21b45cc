"""`lwail sweep`: tasks × seeds × embeddings × methods, each run the usual chain, as Ray tasks of one CPU each.

A plan (``sweep_plan.py``) names the grid and each stage's ``--set`` overrides. Stages that several runs share are
made once: a task's bundled demos, the random data set I of a task and seed (read by every arm of that seed), and
the φ of a task, seed and embedding arm (read by every method of that arm, and by every arm whose pre-training config
is the same). Every artifact is named after the sweep, and each finished stage is recorded in the sweep's ledger
(in the run area, ``.runs/sweep/``) under a fingerprint of its stage, name, config, seed and parents: a restarted
sweep skips what is done (its artifact still there and intact, and for bundled demos, still today's bundle) and
resumes a killed long stage (``pretrain-icvf``, ``imitate``) from its checkpoint.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import signal
import threading
from typing import TYPE_CHECKING, Callable

from .. import config as cfg
from ..artifacts import Store
from ..errors import LwailError, RunPaused
from ..loaders import read_curve
from ..runs import asked_on_signals
from .chain import MAKES, chain_for, reads, run_stage
from .demos import holds_bundled_demos, import_bundled_demos
from .evaluate import evaluate, logged_normalized_evaluation
from .sweep_plan import SweepPlan, SweepRun, plan_from_dict
from .sweep_queue import RunQueue

if TYPE_CHECKING:
    import pandas as pd

    from ..artifacts import Artifact

IMITATING = "imitating"  # the status line whose step and score the driver reads from the run's curve
STATUS = {"pretrain-icvf": "pre-training φ", "warmup-disc": "warming up f", "imitate": IMITATING}  # a run's line while in a stage


# ------------------------------------------------------------------------------ one stage, once
def _once(store: Store, plan: SweepPlan, kind: str, name: str, record: dict, make: Callable[[], Artifact],
          still_current: Callable[[Artifact], bool] = lambda artifact: True, recorded_by_0_3: dict | None = None) -> Artifact:
    """``make()`` unless the ledger holds an intact artifact made from the same stage, name, config, seed and parents
    (and ``still_current``, for inputs the record cannot name). A stage that lwail 0.3 finished is found under the
    fingerprint of ``recorded_by_0_3`` (its record held every field, read or not) and filed under today's."""
    key = _fingerprint(kind, name, record)
    for found_under in [key] + ([_fingerprint(kind, name, recorded_by_0_3)] if recorded_by_0_3 is not None else []):
        done = store.finished_stage(plan.name, found_under, kind, name)
        if done is not None and still_current(done):
            if found_under != key:
                store.runs.record_finished_stage(plan.name, key, done.ref)
            return done
    artifact = make()
    store.runs.record_finished_stage(plan.name, key, artifact.ref)
    return artifact


def _fingerprint(kind: str, name: str, record: dict) -> str:
    return hashlib.sha256(json.dumps({"kind": kind, "name": name, **record}, sort_keys=True, default=str).encode()).hexdigest()[:32]


def bundled_demos(store: Store, plan: SweepPlan, task: str) -> Artifact:
    name = plan.demos_name(task)
    return _once(store, plan, "demos", name, {"task": task}, lambda: import_bundled_demos(store, env_id=task, name=name),
                 still_current=holds_bundled_demos)  # a new bundle is imported as a new version; its runs start over


def collect_task(root: str, plan_dict: dict, task: str, seed: int) -> str:
    """Data set I of a task and seed, shared by the runs of every embedding kind (its ref returned)."""
    store, plan = _worker(root, plan_dict)
    name, config = plan.dataset_name(task, seed), plan.config("collect")
    waiting = [plan.names(run)["policy"] for run in plan.runs if (run.task, run.seed) == (task, seed)]  # the runs that need this data
    for run_name in waiting:
        store.runs.set_sweep_status(plan.name, run_name, "collecting data set I")
    data = _once(store, plan, "dataset", name, {"config": cfg.to_dict(config), "seed": seed, "task": task},
                 lambda: run_stage(store, "collect", made={}, env_id=task, config=config, seed=seed, name=name))
    for run_name in waiting:  # queued again, until a CPU is free for the run itself
        store.runs.clear_sweep_status(plan.name, run_name)
    return data.ref


def embed_task(root: str, plan_dict: dict, task: str, seed: int, kind: str, demos_ref: str, data_ref: str) -> str:
    """The φ of a task, seed and φ arm, shared by the runs of every method of every arm that reads it (its ref returned)."""
    store, plan = _worker(root, plan_dict)
    waiting = [plan.names(run)["policy"] for run in plan.runs if plan.phi_of(run) == (task, seed, kind)]
    for run_name in waiting:
        store.runs.set_sweep_status(plan.name, run_name, STATUS["pretrain-icvf"])
    made = {"demos": store.resolve(demos_ref, "demos"), "dataset": store.resolve(data_ref, "dataset")}
    embedding = _stage(store, plan, SweepRun(task, seed, kind), "pretrain-icvf", made)
    for run_name in waiting:  # queued again, until a CPU is free for the run itself
        store.runs.clear_sweep_status(plan.name, run_name)
    return embedding.ref


def run_task(root: str, plan_dict: dict, task: str, seed: int, kind: str, demos_ref: str, data_ref: str, method: str | None = None,
             embedding_ref: str | None = None) -> dict:
    """One run's own chain: embed (unless ``embedding_ref`` names the φ its arm shares) → warm-up (for a method that
    reads f) → imitate (each resumed from its checkpoint if killed) → evaluate."""
    store, plan = _worker(root, plan_dict)
    run = SweepRun(task, seed, kind, method)
    names = plan.names(run)
    status = functools.partial(store.runs.set_sweep_status, plan.name, names["policy"])  # what the driver shows, from the first second
    made = {"demos": store.resolve(demos_ref, "demos"), "dataset": store.resolve(data_ref, "dataset")}
    if embedding_ref is not None:
        made["embedding"] = store.resolve(embedding_ref, "embedding")
    for stage in chain_for(run.imitation)[1:]:  # a warm-up only for a method that reads f
        if MAKES[stage] not in made:
            status(STATUS[stage])
            made[MAKES[stage]] = _stage(store, plan, run, stage, made)
    status("evaluating")
    eval_config = plan.run_config("eval", run)  # a restart does not evaluate a finished run again
    policy = made["policy"]
    result = (logged_normalized_evaluation(store, policy_ref=policy.ref, config=eval_config)
              or evaluate(store, policy_ref=policy.ref, config=eval_config, normalized=True))
    store.runs.clear_sweep_status(plan.name, names["policy"])  # done: the driver says so from Ray
    return {"run": run.label, "policy": policy.ref, "normalized_score": result["normalized_score"]}


def _stage(store: Store, plan: SweepPlan, run: SweepRun, stage: str, made: dict[str, Artifact]) -> Artifact:
    """One stage of the run's chain on what ``made`` holds, once: its ledger fingerprint is the stage's artifact name,
    config, seed and the parents it reads."""
    import torch

    config, kind = plan.run_config(stage, run), MAKES[stage]
    name = plan.names(run)[kind]
    parents = [made[read] for read in reads(stage, run.imitation)]
    as_0_3 = cfg.recorded_by_0_3(config)
    return _once(store, plan, kind, name, _record(cfg.to_dict(config), run.seed, parents),
                 lambda: run_stage(store, stage, made=made, env_id=run.task, config=config, seed=run.seed, device=torch.device("cpu"),
                                   name=name, resume=store.runs.has_checkpoint(kind, name)),
                 recorded_by_0_3=None if as_0_3 is None else _record(as_0_3, run.seed, parents))


def _record(config: dict, seed: int, parents: list[Artifact]) -> dict:
    return {"config": config, "seed": seed, "parents": [p.hash for p in parents]}


def _worker(root: str, plan_dict: dict) -> tuple[Store, SweepPlan]:
    import torch

    plan = plan_from_dict(plan_dict, "the sweep plan")
    torch.set_num_threads(plan.threads)  # as many threads as Ray CPUs: two multi-threaded torch processes per core run 3-4x slower
    return Store(root), plan


# ------------------------------------------------------------------------------ the driver
def start_ray(ray, address: str | None) -> None:
    """Join the cluster at ``address``, or start a private Ray instance whose workers run at this process's priority."""
    if address is None:
        # Ray's workers otherwise start 15 steps nicer than its raylet (RAY_worker_niceness): any other job on the
        # machine, a test suite at nice 10, would take the cores from the sweep's runs; `nice lwail sweep` still works
        os.environ.setdefault("RAY_worker_niceness", "0")
    # without an address, a private Ray instance: ray.init(None) would join whatever cluster RAY_ADDRESS or the
    # last `ray start` on this machine names, another user's or a dead one
    ray.init(address=address or "local", include_dashboard=False, log_to_driver=False, logging_level="ERROR", configure_logging=False)


def run_sweep(store: Store, *, plan: SweepPlan, runs: list[SweepRun] | None = None, address: str | None = None,
              on_status: Callable[[dict[str, str]], None] | None = None, poll_seconds: float = 5.0) -> list[str]:
    """Run every stage of the plan's ``runs`` (default all; ``sweep_plan.select_runs``) and what they read on Ray;
    returns the runs that failed (each with its error). ``on_status`` gets
    one line per run (queued, step and latest normalized score, done or failed) whenever one changes. A first SIGTERM
    or Ctrl-C to the driver pauses the φs and imitations at work (``lwail pause``: checkpointed where they are), waits
    for them and starts nothing more, then raises a line saying so: the same sweep continues them bit for bit."""
    try:
        import ray
    except ImportError:
        raise LwailError('lwail sweep runs on Ray, which is not installed: pip install "lwail[sweep]"') from None
    root, plan_dict = str(store.root.resolve()), plan.to_dict()
    cores = os.cpu_count() or 1
    if address is None and plan.threads > cores:  # Ray would queue the runs forever
        raise LwailError(f"the plan gives each run {plan.threads} threads; this machine has {cores} cores")
    runs = plan.runs if runs is None else runs
    demos = {task: bundled_demos(store, plan, task).ref for task in dict.fromkeys(run.task for run in runs)}  # a file copy: no Ray task needed
    for run in runs:  # what a killed sweep's runs last said is not what they do now
        store.runs.clear_sweep_status(plan.name, plan.names(run)["policy"])
    start_ray(ray, address)
    stop = threading.Event()  # SIGTERM or Ctrl-C: pause the runs at work, start nothing more
    paused: list[str] = []
    try:
        collect_remote, run = ray.remote(num_cpus=1)(collect_task), ray.remote(num_cpus=plan.threads, max_retries=0)(run_task)
        embed_remote = ray.remote(num_cpus=plan.threads, max_retries=0)(embed_task)
        data = {(t, s): collect_remote.remote(root, plan_dict, t, s) for t, s in dict.fromkeys((run.task, run.seed) for run in runs)}
        queue = RunQueue(list(runs), places=max(1, int(ray.cluster_resources().get("CPU", 1)) // plan.threads), phi_of=plan.phi_of)
        phi: dict = {}  # plan.phis: (task, seed, φ arm) -> its φ, started when the first run reading it is handed out
        making: dict = {}  # a φ in training -> its arm
        pending: dict = {}  # a run given to Ray -> the run
        status = {r.label: "queued" for r in runs}
        failures: list[str] = []
        shown: dict[str, str] = {}
        with asked_on_signals(stop, (signal.SIGTERM, signal.SIGINT)):
            while pending or making or (queue.unfinished() and not stop.is_set()):
                if stop.is_set():  # asked again at every poll: a run that opens after the first ask is asked too
                    _ask_to_pause(store, plan, phis=making.values(), runs=pending.values())
                else:
                    phis, handed = queue.take()
                    for task, seed, kind in phis:
                        phi[task, seed, kind] = embed_remote.remote(root, plan_dict, task, seed, kind, demos[task], data[(task, seed)])
                        making[phi[task, seed, kind]] = (task, seed, kind)
                    for r in handed:
                        pending[run.remote(root, plan_dict, r.task, r.seed, r.kind, demos[r.task], data[(r.task, r.seed)], r.method,
                                           phi[plan.phi_of(r)])] = r
                watched = [*pending, *making]
                done, _ = ray.wait(watched, num_returns=len(watched), timeout=poll_seconds)
                for ref in done:
                    if ref in making:  # a φ made (or failed: its runs fail with its error when they read it)
                        queue.phi_made(making.pop(ref))
                        continue
                    finished = pending.pop(ref)
                    queue.run_ended()
                    try:
                        status[finished.label] = f"done, normalized score {ray.get(ref)['normalized_score']:.1f}"
                    except Exception as exc:  # a run's failure is reported, the others go on
                        cause = getattr(exc, "cause", None) or exc
                        status[finished.label] = f"failed: {cause}"
                        failures.append(f"{finished.label}: {cause}")
                        if isinstance(cause, RunPaused):
                            paused.append(f"{finished.label} at step {cause.step}")
                for unfinished in [*pending.values(), *queue.parked, *queue.waiting]:
                    status[unfinished.label] = _live_status(store, plan, unfinished) or "queued"
                if on_status is not None and status != shown:
                    on_status(dict(status))
                    shown = dict(status)
    finally:
        ray.shutdown()
    if stop.is_set():
        raise LwailError(f"the sweep stopped as asked; paused with their checkpoints kept: {'; '.join(paused) or 'none (no run was at work)'}; "
                         f"failed: {len(failures) - len(paused)}; the rest not started. Run the same sweep again to continue")
    return failures


def _ask_to_pause(store: Store, plan: SweepPlan, *, phis, runs) -> None:
    """Ask the φ pre-trainings and imitations of the Ray tasks still at work to checkpoint and stop (a collection or
    warm-up at work is not asked: it ends, and the stage it hands to is asked at the next poll)."""
    for name in [plan.phi_name(*phi) for phi in phis] + [plan.names(run)["policy"] for run in runs]:
        store.runs.request_pause(name, missing_ok=True)


def _live_status(store: Store, plan: SweepPlan, run: SweepRun) -> str | None:
    """What a run does now, as its Ray task last said (None before it starts: queued; or, when a killed sweep left its
    imitation checkpointed, queued with how far that got); while it imitates, with the step and latest normalized
    score of its curve."""
    name = plan.names(run)["policy"]
    line = store.runs.sweep_status(plan.name, name)
    if line is None and store.runs.has_checkpoint("policy", name):
        last = _last_evaluation(store, name)
        return "queued, its imitation checkpointed" + ("" if last is None else f" (curve to step {int(last['step'])})")
    if line != IMITATING:
        return line
    curve = _curve(store, name)
    if curve is None:
        return f"{IMITATING}: before the first evaluation"
    last, total = curve.iloc[-1], plan.run_config("imitate", run).train.steps
    score = f", normalized score {last['normalized_score']:.1f}" if "normalized_score" in last else ""
    return f"{IMITATING}: step {int(last['step'])} of {total}{score}{_pace(curve, total)}"


PACE_EVALUATIONS = 6  # the pace of a run is read over its last evaluations: recent enough to follow what shares its cores


def _pace(curve: pd.DataFrame, total: int) -> str:
    """Env steps per second over the last evaluations and the time left at that pace; nothing until there are two."""
    recent = curve.tail(PACE_EVALUATIONS)
    if "wall_time" not in recent or len(recent) < 2:
        return ""
    steps = float(recent["step"].iloc[-1] - recent["step"].iloc[0])
    seconds = float(recent["wall_time"].iloc[-1] - recent["wall_time"].iloc[0])
    if steps <= 0 or seconds <= 0:
        return ""
    rate = steps / seconds
    return f", {rate:.0f} env-steps/s, ~{max(total - recent['step'].iloc[-1], 0) / rate / 3600:.1f} h to go"


def _last_evaluation(store: Store, name: str) -> pd.Series | None:
    curve = _curve(store, name)
    return None if curve is None else curve.iloc[-1]


def _curve(store: Store, name: str) -> pd.DataFrame | None:
    try:
        curve, _ = read_curve(store, ref=name)
    except LwailError:  # no evaluation yet
        return None
    return None if curve.empty else curve
