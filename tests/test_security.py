"""Nothing read from disk may run code."""

import json
import os

import numpy as np
import pytest
import torch

from conftest import committed_versions, write_states_npz
from lwail_cli.manifests import content_hash, manifest_hash
from lwail_cli.errors import LwailError


class Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_pickle_planted_in_a_checkpoint_is_refused_without_running(cli, store, tmp_path):
    marker = tmp_path / "pwned"
    path = store.root / ".runs" / "policy" / "run" / "checkpoint.pt"
    path.parent.mkdir(parents=True)
    torch.save({"record": Payload(marker)}, path)
    before = committed_versions(store)
    result = cli("expert", "train", "InvertedPendulum-v5", "--steps", "10", "--name", "run", "--resume")
    assert result.exit_code == 1 and "is corrupt" in result.output and "Traceback" not in result.output
    assert not marker.exists()
    assert committed_versions(store) == before


def _tamper(artifact, change):
    manifest_path = artifact.path / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    change(manifest)
    manifest_path.write_text(json.dumps(manifest))


def test_manifest_paths_and_module_env_ids_are_refused(cli, store, tmp_path):
    write_states_npz(tmp_path / "d.npz", episodes=2, obs_dim=4, returns=[1.0, 2.0])
    assert cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", "d").exit_code == 0
    artifact = store.resolve("d", "demos")
    _tamper(artifact, lambda m: m["files"].update({"../../../../etc/hostname": "0" * 64}))
    result = cli("show", "demos/d")
    assert result.exit_code == 1 and "outside its artifact" in result.output
    assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
    def forge(m):  # a careful forger recomputes both hashes
        m["files"].pop("../../../../etc/hostname")
        m["env"]["id"] = "os:system"
        m["hash"] = content_hash(m["files"], m["env"], m["config"])
        m["manifest_hash"] = manifest_hash(m)

    _tamper(artifact, forge)
    with pytest.raises(LwailError, match="names a module to import"):
        store.resolve("d", "demos").env  # every stage reads an artifact's env through here


def test_minari_ids_stay_inside_the_local_store(cli, store, tmp_path):
    for dataset_id in ("../elsewhere/data-v0", str(tmp_path / "abs-v0")):
        result = cli("demos", "import", "InvertedPendulum-v5", "--from-minari", dataset_id)
        assert result.exit_code == 1 and "inside the local Minari store" in result.output, result.output
        assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
        assert committed_versions(store) == []


def test_any_edit_of_a_manifest_is_detected_and_a_damaged_store_still_lists(cli, store, tmp_path):
    write_states_npz(tmp_path / "d.npz", episodes=2, obs_dim=4, returns=[1.0, 2.0])
    for name in ("d", "e"):
        assert cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", name).exit_code == 0
    intact = cli("verify")
    assert intact.exit_code == 0 and intact.output.count("ok ") == 2 and "2 artifact versions checked, 0 damaged" in intact.output
    _tamper(store.resolve("d", "demos"), lambda m: m["metrics"].update(mean_return=9999.0))  # a flattering reference
    assert cli("show", "demos/d").exit_code == 1
    assert "manifest hash does not match" in cli("show", "demos/d").output
    (store.resolve("e", "demos").path / "manifest.json").write_text("{ not json")
    listing = cli("ls")
    assert listing.exit_code == 0 and "DAMAGED" in listing.output and "demos" in listing.output
    verified = cli("verify")
    assert verified.exit_code == 1 and verified.output.count("DAMAGED") == 2 and "2 damaged" in verified.output


def test_a_parent_changed_after_its_child_was_made_is_refused(cli, store, tmp_path):
    write_states_npz(tmp_path / "data.npz", episodes=3, obs_dim=4)
    write_states_npz(tmp_path / "d.npz", episodes=2, obs_dim=4, returns=[1.0, 2.0])
    assert cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "data.npz", "--name", "data").exit_code == 0
    assert cli("demos", "import", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", "d").exit_code == 0
    assert cli("pretrain-icvf", "data", "--kind", "identity", "--name", "ident").exit_code == 0
    data = store.resolve("data", "dataset")

    def rename(m):  # the edit is re-hashed, so only the child's record of its parent can tell
        m["metrics"]["episodes"] = 99
        m["manifest_hash"] = manifest_hash(m)

    _tamper(data, rename)
    before = committed_versions(store)
    result = cli("warmup-disc", "ident", "d", "--set", "steps=2")
    assert result.exit_code == 1 and "was changed after embedding/ident@v1 was made from it" in result.output
    assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
    assert committed_versions(store) == before  # no discriminator written


def test_a_minari_env_spec_never_runs(cli, store, tmp_path, monkeypatch):
    """Minari rebuilds the env from a dataset's env_spec when it has no stored spaces; lwail never lets it."""
    from lwail_cli.config import CollectConfig
    from lwail_cli.stages.collect import collect
    import shutil

    collected = collect(store, env_id="InvertedPendulum-v5", config=CollectConfig(transitions=60), seed=0)
    source = collected.file("minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    data = tmp_path / "minari" / "evil" / "random-v0" / "data"
    shutil.copytree(source, data)
    marker = tmp_path / "pwned"
    metadata = json.loads((data / "metadata.json").read_text())
    for key in ("observation_space", "action_space"):
        metadata.pop(key)
    spec = json.loads(metadata["env_spec"])
    spec.update(entry_point="os:system", kwargs={"command": f"touch {marker}"})
    metadata.update(env_spec=json.dumps(spec), dataset_id="evil/random-v0")
    (data / "metadata.json").write_text(json.dumps(metadata))
    for command in (("demos", "import"), ("collect",)):
        result = cli(*command, "InvertedPendulum-v5", "--from-minari", "evil/random-v0", "--name", "imported")
        assert result.exit_code == 0, result.output
    assert cli("pretrain-icvf", "imported", "--kind", "identity").exit_code == 0  # reads the dataset artifact back
    assert not marker.exists()
    from lwail_cli import load_episodes

    expected = load_episodes(collected.ref, store=store.root)
    for kind in ("demos", "dataset"):  # both imports hold the dataset's states, read with spaces lwail built itself
        imported = load_episodes(f"{kind}/imported", store=store.root)
        assert np.array_equal(imported["observations"], expected["observations"])
        assert np.array_equal(imported["episode_ends"], expected["episode_ends"])
