"""SIGKILL real `lwail` processes of each long stage at random moments and resume them each time: the result is
byte for byte the unkilled run's (atomic checkpoints, a dead owner's lock taken over, nothing half-written)."""

import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from lwail_cli import config as cfg
from lwail_cli.artifacts import Store
from lwail_cli.stages import collect, demos, embed, warmup

TD3_SMALL = ["--set", "td3.random_steps=300", "--set", "td3.learning_starts=300", "--set", "td3.hidden=(32,32)", "--set", "td3.batch_size=64"]
STAGES = {  # stage -> (kind, command after `lwail`, the file compared)
    "expert train": ("policy", ["expert", "train", "InvertedPendulum-v5", "--steps", "2500", "--eval-every", "500",
                                "--checkpoint-every", "200", *TD3_SMALL], "final_actor.safetensors"),
    "pretrain-icvf": ("embedding", ["pretrain-icvf", "data", "--steps", "600", "--set", "icvf.checkpoint_every=50",
                                    "--set", "icvf.log_every=50", "--set", "icvf.hidden=(64,)", "--set", "icvf.embedding_dim=32"], "phi.safetensors"),
    "imitate": ("policy", ["imitate", "InvertedPendulum-v5", "--demos", "demos", "--embedding", "identity", "--disc", "disc",
                           "--steps", "2000", "--eval-every", "500", "--checkpoint-every", "200", "--set", "update_every=400",
                           "--set", "update_steps=3", *TD3_SMALL], "actor.safetensors"),
}


def _prepare(store):
    bundled = demos.import_bundled_demos(store, env_id="InvertedPendulum-v5", name="demos")
    data = collect.collect(store, env_id="InvertedPendulum-v5", config=cfg.CollectConfig(transitions=2000), seed=0, name="data")
    identity = embed.embed(store, data_ref=data.ref, config=cfg.EmbedConfig(kind="identity"), seed=0, name="identity", device="cpu")
    warm = cfg.WarmupConfig(critic=cfg.CriticConfig(hidden=(16, 16)), steps=5)
    warmup.warmup(store, embedding_ref=identity.ref, demos_ref=bundled.ref, config=warm, seed=0, name="disc", device="cpu")


def _run(root, args, name, resume):
    command = [sys.executable, "-m", "lwail_cli", "--store", str(root), "--threads", "1", *args, "--name", name]
    return command + (["--resume"] if resume else [])


@pytest.mark.slow
@pytest.mark.parametrize("stage", list(STAGES))
def test_random_sigkills_then_resume_give_the_unkilled_result(tmp_path, stage):
    kind, args, compared = STAGES[stage]
    root = tmp_path / "store"
    store = Store(root)
    _prepare(store)
    subprocess.run(_run(root, args, "straight", False), check=True, capture_output=True)
    rng = np.random.default_rng(0)
    kills = 0
    for delay in rng.uniform(2.5, 6.0, size=4):
        process = subprocess.Popen(_run(root, args, "killed", store.runs.has_checkpoint(kind, "killed")), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        if process.poll() is None:
            process.send_signal(signal.SIGKILL)
            kills += 1
        process.wait()
    finish = subprocess.run(_run(root, args, "killed", store.runs.has_checkpoint(kind, "killed")), capture_output=True, text=True)
    assert finish.returncode == 0, finish.stderr
    assert kills >= 2  # the test must have killed something
    straight, killed = store.resolve("straight", kind), store.resolve("killed", kind)
    assert straight.file(compared).read_bytes() == killed.file(compared).read_bytes()
    assert not (root / ".runs" / kind / "killed").exists() and not list((root / ".tmp").iterdir())


def _checkpoint_step(store, kind):
    state = store.runs.load_checkpoint(kind, "paused")
    return state["run"]["step"] if kind == "policy" else state["step"]


@pytest.mark.slow
@pytest.mark.parametrize("stage", list(STAGES))
def test_sigterm_pauses_a_real_run_of_each_long_stage_and_resume_gives_the_unpaused_result(tmp_path, stage):
    """A first SIGTERM (what `kill` and a scheduler's preemption send) checkpoints the run where it is and ends it
    with one line; a `pretrain-icvf` once ignored it and trained on."""
    kind, args, compared = STAGES[stage]
    root = tmp_path / "store"
    store = Store(root)
    _prepare(store)
    subprocess.run(_run(root, args, "straight", False), check=True, capture_output=True)
    process = subprocess.Popen(_run(root, args, "paused", False), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not store.runs.has_checkpoint(kind, "paused") and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # its first checkpoint: the run is training, its SIGTERM handler set
    process.send_signal(signal.SIGTERM)
    error = process.communicate(timeout=60)[1]
    paused_at = re.search(r"error: paused at step (\d+) as asked", error)
    assert process.returncode == 1 and paused_at is not None and "Traceback" not in error, error
    assert _checkpoint_step(store, kind) == int(paused_at[1])
    finish = subprocess.run(_run(root, args, "paused", True), capture_output=True, text=True)
    assert finish.returncode == 0, finish.stderr
    straight, resumed = store.resolve("straight", kind), store.resolve("paused", kind)
    assert straight.file(compared).read_bytes() == resumed.file(compared).read_bytes()
