"""SIGKILL a real `lwail expert train` process at random moments, resume it each time: the result is byte for
byte the unkilled run's (atomic checkpoints, a dead owner's lock taken over, nothing half-written)."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from lwail_cli.artifacts import Store


def _command(store, name, resume):
    return [sys.executable, "-m", "lwail_cli", "--store", str(store), "--threads", "1", "expert", "train", "InvertedPendulum-v5",
            "--steps", "2500", "--eval-every", "500", "--checkpoint-every", "200", "--name", name, "--set", "td3.random_steps=300",
            "--set", "td3.learning_starts=300", "--set", "td3.hidden=(32,32)", "--set", "td3.batch_size=64"] + (["--resume"] if resume else [])


@pytest.mark.slow
def test_random_sigkills_then_resume_give_the_unkilled_result(tmp_path):
    root = tmp_path / "store"
    subprocess.run(_command(root, "straight", False), check=True, capture_output=True)
    store = Store(root)
    rng = np.random.default_rng(0)
    kills = 0
    for delay in rng.uniform(2.0, 6.0, size=4):
        process = subprocess.Popen(_command(root, "killed", store.has_checkpoint("policy", "killed")),
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        time.sleep(delay)
        if process.poll() is None:
            process.send_signal(signal.SIGKILL)
            kills += 1
        process.wait()
    finish = subprocess.run(_command(root, "killed", store.has_checkpoint("policy", "killed")), capture_output=True, text=True)
    assert finish.returncode == 0, finish.stderr
    assert kills >= 2  # the test must have killed something
    straight, killed = store.resolve("straight", "policy"), store.resolve("killed", "policy")
    assert straight.file("final_actor.safetensors").read_bytes() == killed.file("final_actor.safetensors").read_bytes()
    assert not (root / ".runs" / "policy" / "killed").exists() and not list((root / ".tmp").iterdir())
