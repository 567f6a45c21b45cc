"""Episodes as MP4 files, rendered headless (MuJoCo through EGL unless MUJOCO_GL says otherwise)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np

from .envs import make_env
from .errors import LwailError
from .rollout import Policy, Rollouts, rollout

VIDEO_FPS = 30  # frames kept per second of simulated time (MuJoCo tasks step at 67-125 Hz)


def filmed_rollout(env_id: str, policy: Policy | None, seeds: Sequence[int], directory: Path, prefix: str, *, record: bool = False,
                  start_noise: float = 0.0) -> tuple[Rollouts, list[Path]]:
    """``rollout`` with one MP4 per episode in ``directory``, named ``<prefix>-seed<S>-return<R>.mp4``."""
    try:
        import imageio.v2 as imageio
    except ImportError:
        raise LwailError('--video needs imageio and imageio-ffmpeg: pip install "lwail[video]"') from None
    os.environ.setdefault("MUJOCO_GL", "egl")  # headless by default; gymnasium reads it when it makes a renderer
    env_fps = _check_rendering(env_id)
    every = max(1, round(env_fps / VIDEO_FPS))
    directory.mkdir(parents=True, exist_ok=True)
    partial = [directory / f".{prefix}-seed{seed}.partial.mp4" for seed in seeds]
    writers: dict[int, object] = {}

    def on_frame(index: int, frame: np.ndarray) -> None:
        if index not in writers:
            writers[index] = imageio.get_writer(partial[index], format="FFMPEG", fps=env_fps / every, macro_block_size=1)
        writers[index].append_data(frame)

    try:
        try:
            played = rollout(env_id, policy, seeds, record=record, on_frame=on_frame, frame_every=every, start_noise=start_noise)
        finally:
            for writer in writers.values():
                writer.close()
    except BaseException:  # an interrupted film is not a video: leave nothing half-written behind
        for path in partial:
            path.unlink(missing_ok=True)
        raise
    videos = []
    for path, seed, episode_return in zip(partial, seeds, played.returns):
        videos.append(path.rename(directory / f"{prefix}-seed{seed}-return{episode_return:.0f}.mp4"))
    return played, videos


def _check_rendering(env_id: str) -> float:
    """Render one frame before the real work, so a missing backend is one clear line; returns the env's fps."""
    try:
        env = make_env(env_id, render=True)
        try:
            env.reset(seed=0)
            frame = env.render()
            fps = float(env.metadata.get("render_fps") or VIDEO_FPS)
        finally:
            env.close()
    except LwailError:
        raise
    except Exception as exc:  # each GL backend fails in its own way (ImportError, RuntimeError, mujoco.FatalError)
        backend = os.environ.get("MUJOCO_GL", "default")
        raise LwailError(f"cannot render {env_id} headless with MUJOCO_GL={backend} ({type(exc).__name__}: {exc}); "
                         "EGL needs libEGL (e.g. apt install libegl1); or try MUJOCO_GL=osmesa") from None
    if not isinstance(frame, np.ndarray) or frame.ndim != 3:
        raise LwailError(f"{env_id} renders no RGB frames")
    return fps
