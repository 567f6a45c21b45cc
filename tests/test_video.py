"""`eval --video` and `expert record --video`: one MP4 per episode, headless, or one clear line saying why not."""

import sys

import numpy as np
import pytest

from conftest import committed_versions


@pytest.fixture
def policy(cli, store):
    result = cli("expert", "train", "InvertedPendulum-v5", "--steps", "400", "--eval-every", "400",
                 "--set", "td3.random_steps=300", "--set", "td3.learning_starts=300", "--set", "td3.hidden=(16,16)", "--name", "p")
    assert result.exit_code == 0, result.output
    return "p"


def test_eval_writes_one_playable_mp4_per_episode_named_by_its_return(cli, store, policy, tmp_path):
    imageio = pytest.importorskip("imageio.v2")
    result = cli("eval", policy, "--episodes", "2", "--video", tmp_path / "videos")
    assert result.exit_code == 0, result.output
    videos = sorted((tmp_path / "videos").glob("*.mp4"))
    assert [v.name.split("-return")[0] for v in videos] == ["p-v1-seed100", "p-v1-seed101"]
    for video in videos:
        episode_return = int(video.stem.split("-return")[1])
        frames = imageio.mimread(video)
        # InvertedPendulum earns 1 per step but 0 on the falling one, and renders at 25 fps (< 30): every frame is kept
        assert len(frames) == (episode_return + 1) + 1 and frames[0].shape == (480, 480, 3) and frames[0].std() > 10
    assert not list((tmp_path / "videos").glob(".*"))  # no partial files left


def test_expert_record_films_the_episodes_it_records(cli, store, policy, tmp_path):
    imageio = pytest.importorskip("imageio.v2")
    result = cli("expert", "record", policy, "--episodes", "2", "--name", "d", "--video", tmp_path / "videos")
    assert result.exit_code == 0, result.output
    assert len(list((tmp_path / "videos").glob("p-v1-seed*-return*.mp4"))) == 2
    recorded = store.resolve("d", "demos")
    assert recorded.metrics["episodes"] == 2
    with np.load(recorded.file("demos.npz")) as arrays:
        lengths = np.diff(np.concatenate([[-1], np.flatnonzero(arrays["episode_ends"])])).tolist()  # observations per episode
        returns = arrays["returns"].tolist()
    videos = sorted((tmp_path / "videos").glob("*.mp4"), key=lambda v: int(v.name.split("-seed")[1].split("-")[0]))
    # the episodes filmed are the ones recorded: one video per recorded episode, named by its return, one frame per state
    assert [v.name for v in videos] == [f"p-v1-seed{s}-return{r:.0f}.mp4" for s, r in zip((0, 1), returns)]
    assert [len(imageio.mimread(v)) for v in videos] == lengths


def test_missing_video_support_is_one_clear_line(cli, store, policy, tmp_path, monkeypatch):
    before = committed_versions(store)
    with monkeypatch.context() as patch:
        patch.setitem(sys.modules, "imageio.v2", None)
        result = cli("eval", policy, "--video", tmp_path / "v")
    assert result.exit_code == 1 and 'pip install "lwail[video]"' in result.output
    assert "Traceback" not in result.output and result.output.strip().count("\n") == 0, result.output
    assert committed_versions(store) == before
    pytest.importorskip("imageio")
    monkeypatch.setenv("MUJOCO_GL", "no-such-backend")
    result = cli("eval", policy, "--video", tmp_path / "v")
    assert result.exit_code == 1 and "cannot render InvertedPendulum-v5 headless with MUJOCO_GL=no-such-backend" in result.output
    assert "Traceback" not in result.output and committed_versions(store) == before
    assert result.output.strip().count("\n") == 0, result.output


def test_an_interrupted_film_leaves_no_partial_file(tmp_path, monkeypatch):
    pytest.importorskip("imageio.v2")
    from lwail_cli import video

    def rollout_that_fails_mid_film(*args, on_frame, **kwargs):
        on_frame(0, np.zeros((64, 64, 3), dtype=np.uint8))
        raise KeyboardInterrupt

    monkeypatch.setattr(video, "rollout", rollout_that_fails_mid_film)
    with pytest.raises(KeyboardInterrupt):
        video.filmed_rollout("InvertedPendulum-v5", None, [0, 1], tmp_path / "videos", "p")
    assert list((tmp_path / "videos").iterdir()) == []
