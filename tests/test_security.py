"""Nothing read from disk may run code."""

import os

import torch

from conftest import committed_versions


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
