import json
import os

import pytest

from lwail_cli.envs import describe_env
from lwail_cli.errors import LwailError
from lwail_cli.manifests import SCHEMA_VERSION

ENV = describe_env("InvertedPendulum-v5")


def write(store, name="demo", payload=b"weights", kind="embedding", parents=()):
    with store.create(kind, name, env=ENV, config={"lr": 0.1}, seed=3, parents=list(parents)) as writer:
        writer.path("data.bin").write_bytes(payload)
        writer.metrics["score"] = 1.5
    return store.resolve(f"{kind}/{name}", kind)


def test_round_trip_records_manifest_and_data(store):
    artifact = write(store)
    assert artifact.file("data.bin").read_bytes() == b"weights"
    manifest = artifact.manifest
    assert (manifest["kind"], manifest["name"], manifest["version"], manifest["schema_version"]) == ("embedding", "demo", 1, SCHEMA_VERSION)
    assert manifest["env"]["id"] == "InvertedPendulum-v5" and manifest["env"]["obs_dim"] == 4
    assert manifest["config"] == {"lr": 0.1} and manifest["seed"] == 3 and manifest["metrics"] == {"score": 1.5}
    assert set(manifest) >= {"package_version", "created", "files", "hash", "parents"}


def test_rerun_writes_a_new_version_and_refs_resolve(store):
    first = write(store, payload=b"one")
    second = write(store, payload=b"two")
    assert (first.version, second.version) == (1, 2)
    assert store.resolve("demo", "embedding").version == 2
    assert store.resolve("demo@v1", "embedding").file("data.bin").read_bytes() == b"one"
    assert store.resolve(str(first.path), "embedding").version == 1
    child = write(store, name="child", kind="discriminator", parents=[first])
    assert child.manifest["parents"] == [{"ref": "embedding/demo@v1", "hash": first.hash, "manifest_hash": first.manifest["manifest_hash"]}]


def test_crash_while_writing_leaves_no_visible_version(store):
    write(store)
    with pytest.raises(RuntimeError):
        with store.create("embedding", "demo", env=ENV, config={}, seed=0) as writer:
            writer.path("data.bin").write_bytes(b"half")
            raise RuntimeError("killed mid-write")
    assert store.resolve("demo", "embedding").version == 1
    assert [v for _, _, v, _ in store.list()] == [[1]]
    assert not any((store.root / ".tmp").iterdir())


def test_validation_refuses_tampering_wrong_kind_schema_and_missing(store):
    artifact = write(store)
    with pytest.raises(LwailError, match="is a embedding artifact, but a policy is needed"):
        store.resolve("demo", "policy")
    with pytest.raises(LwailError, match="no version v7"):
        store.resolve("demo@v7", "embedding")
    with pytest.raises(LwailError, match="no embedding artifact named 'other'"):
        store.resolve("other", "embedding")
    artifact.file("data.bin").write_bytes(b"tampered")
    with pytest.raises(LwailError, match="does not match its recorded hash"):
        store.resolve("demo", "embedding")
    artifact.file("data.bin").write_bytes(b"weights")
    manifest = json.loads(artifact.file("manifest.json").read_text())
    manifest["schema_version"] = SCHEMA_VERSION + 1
    artifact.file("manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(LwailError, match="schema version"):
        store.resolve("demo", "embedding")


def test_corrupt_checkpoint_is_refused_clearly(store):
    store.runs.save_checkpoint("policy", "run", {"step": 5, "record": {"seed": 0}})
    assert store.runs.load_checkpoint("policy", "run") == {"step": 5, "record": {"seed": 0}}
    path = store.root / ".runs" / "policy" / "run" / "checkpoint.pt"
    path.write_bytes(b"garbage" * 10)
    with pytest.raises(LwailError, match="corrupt"):
        store.runs.load_checkpoint("policy", "run")


def test_the_run_area_keeps_the_layout_that_runs_in_flight_wrote(store):
    """Checkpoints, run logs and a sweep's ledger sit where earlier versions of lwail put them, so a run killed (or
    still training) under an earlier version resumes under this one."""
    artifact = write(store)
    store.runs.save_checkpoint("policy", "run", {"step": 5, "record": {"seed": 0}})
    store.runs.write_run_log("policy", "run", "learning_curve.csv", [{"step": 1, "return": 2.5}, {"step": 2, "score": 1}])
    store.runs.record_finished_stage("sw", "0123abcd", artifact.ref)
    store.runs.set_sweep_status("sw", "run", "imitating")
    runs = store.root / ".runs"
    assert sorted(str(path.relative_to(runs)) for path in runs.rglob("*") if path.is_file()) == [
        "policy/run/checkpoint.pt", "policy/run/learning_curve.csv", "sweep/sw/0123abcd.ref", "sweep/sw/run.status"]
    assert (runs / "policy/run/learning_curve.csv").read_bytes() == b"step,return,score\r\n1,2.5,\r\n2,,1\r\n"
    assert (runs / "sweep/sw/0123abcd.ref").read_text() == "embedding/demo@v1"
    assert store.finished_stage("sw", "0123abcd", "embedding", "demo") == artifact
    assert store.runs.sweep_status("sw", "run") == "imitating"


def test_a_run_file_is_replaced_whole_or_not_at_all(store):
    store.runs.save_checkpoint("policy", "run", {"step": 5, "record": {"seed": 0}})
    with pytest.raises(Exception):  # pickling fails halfway through writing the new checkpoint
        store.runs.save_checkpoint("policy", "run", {"step": 6, "record": {"seed": 0}, "unsaveable": lambda: None})
    assert store.runs.load_checkpoint("policy", "run")["step"] == 5
    store.runs.run_log("policy", "run", "learning_curve.csv").mkdir()  # damage: a folder where the log goes
    store.runs.write_run_log("policy", "run", "learning_curve.csv", [{"step": 1}])
    assert store.runs.run_log("policy", "run", "learning_curve.csv").read_bytes() == b"step\r\n1\r\n"


def test_a_store_that_refuses_writes_is_a_clear_error_not_a_hang(store, monkeypatch):
    import os

    def refuse(source, target):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "rename", refuse)
    with pytest.raises(LwailError, match="cannot write .*Permission denied"):
        write(store)
    monkeypatch.undo()
    assert store.list() == [] and not list((store.root / ".tmp").iterdir())  # nothing half-written, nothing left over


def test_a_writer_killed_mid_write_leaves_no_folder_behind_for_long(store):
    import socket
    import subprocess

    tmp = store.root / ".tmp"
    tmp.mkdir(parents=True)
    with subprocess.Popen(["true"]) as gone:
        pass
    abandoned = tmp / f"{socket.gethostname()}+{gone.pid}+demos-x-abc"
    live = tmp / f"{socket.gethostname()}+{os.getpid()}+demos-y-abc"
    elsewhere = tmp / f"another-host+{gone.pid}+demos-z-abc"  # cannot tell from here: kept
    for folder in (abandoned, live, elsewhere):
        folder.mkdir()
    with store.create("demos", "d", env=describe_env("InvertedPendulum-v5"), config={}, seed=None) as writer:
        writer.path("a.txt").write_text("a")
    assert sorted(p.name for p in tmp.iterdir()) == sorted([live.name, elsewhere.name])
