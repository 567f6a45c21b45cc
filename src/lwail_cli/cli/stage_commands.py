"""The commands of the chain's stages: collect, expert train and record, demos import, pretrain-icvf, warmup-disc,
imitate. Each builds its config (``command(..., config=)``), runs its stage inside a progress bar and says what it wrote."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from .. import config as cfg
from ..embeddings import unread_settings
from ..errors import LwailError
from ..stages import collect as collect_stage
from ..stages import demos as demos_stage
from ..stages import embed as embed_stage
from ..stages import expert as expert_stage
from ..stages import imitate as imitate_stage
from ..stages import online as online_stage
from ..stages import warmup as warmup_stage
from ..stages.chain import work
from ..stages.shared import resolve_device
from .app import DEVICE, NAME, SEED, VIDEO, app, command, demos_app, expert_app, progress_bar, refuse_unread_settings, resume_option, say_written, store


# ------------------------------------------------------------------------------ data
@command(app, "collect", config=cfg.CollectConfig)
def collect(
    env_id: str = typer.Argument(..., metavar="ENV_ID", help="Gymnasium environment id, e.g. Hopper-v5."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", metavar="DATASET_ID", help="Import a dataset from the local Minari store (never downloads)."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", metavar="FILE", help="Import a .npz with 'observations' and 'episode_ends'."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    *,
    config: cfg.CollectConfig,
) -> None:
    """Collect state-only data from a uniformly random policy (or import it) as a Minari dataset."""
    if from_minari and from_file:
        raise LwailError("give one source: --from-minari or --from-file (neither: collect from a random policy)")
    if from_minari or from_file:
        refuse_unread_settings(config, seed, settings="--transitions, --start-noise", reader="collecting from a random policy")
        artifact = collect_stage.import_dataset(store(), env_id=env_id, name=name, minari_id=from_minari, npz=from_file)
    else:
        with progress_bar(f"collect {env_id}", config.transitions) as report:
            artifact = collect_stage.collect(store(), env_id=env_id, config=config, seed=seed, name=name, on_progress=report)
    say_written(artifact)


# ------------------------------------------------------------------------------ experts & demos
@command(expert_app, "train", config=cfg.ExpertConfig)
def expert_train(
    env_id: str = typer.Argument(..., metavar="ENV_ID", help="Gymnasium environment id with a continuous action space."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = resume_option(cfg.ExpertConfig, "run"),
    *,
    config: cfg.ExpertConfig,
) -> None:
    """Train a TD3 expert on the environment's true reward (the paper's TD3 baseline)."""
    with progress_bar(f"expert {env_id}", config.train.steps, online_stage.budget_warnings(config)) as report:
        artifact = expert_stage.train_expert(
            store(), env_id=env_id, config=config, seed=seed, name=name, device=resolve_device(device), resume=resume, on_progress=report
        )
    say_written(artifact)


@command(expert_app, "record", config=cfg.RecordConfig)
def expert_record(
    policy: str = typer.Argument(..., metavar="POLICY", help="Policy artifact: name, name@vN or a path."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    video: Optional[Path] = VIDEO,
    *,
    config: cfg.RecordConfig,
) -> None:
    """Roll a policy out and record state-only demonstrations with each episode's return."""
    say_written(demos_stage.record_demos(store(), policy_ref=policy, config=config, seed=seed, name=name, video_dir=video))


@command(demos_app, "import", config=cfg.RecordConfig)
def demos_import(
    env_id: str = typer.Argument(..., metavar="ENV_ID", help="Environment the demonstrations come from."),
    from_minari: Optional[str] = typer.Option(None, "--from-minari", metavar="DATASET_ID", help="A dataset id in the local Minari store."),
    from_file: Optional[Path] = typer.Option(None, "--from-file", metavar="FILE", help="A .npz with 'observations', 'episode_ends' (and optional 'returns')."),
    bundled: bool = typer.Option(False, "--bundled", help="The demos shipped with lwail for this env."),
    from_imitation: Optional[Path] = typer.Option(
        None, "--from-imitation", metavar="PATH", help="Trajectories saved by the imitation library (imitation.data.serialize.save: a folder, or its older .npz)."),
    from_sb3: Optional[Path] = typer.Option(None, "--from-sb3", metavar="FILE", help="Roll out a Stable-Baselines3 model.zip (read as data, never unpickled)."),
    planner: bool = typer.Option(False, "--planner", help="Roll out the maze planner expert (PointMaze tasks: shortest path and PD control, as D4RL's maze2d)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    *,
    config: cfg.RecordConfig,
) -> None:
    """Import state-only demonstrations: a local Minari dataset, a .npz, imitation's trajectories, an SB3 model's
    or the maze planner's rollouts (--episodes of them), or the bundled set."""
    if sum(map(bool, (bundled, from_sb3, planner, from_minari, from_file, from_imitation))) > 1:
        raise LwailError("give one source: --bundled, --from-sb3, --planner, --from-minari, --from-file or --from-imitation")
    if from_sb3 is None and not planner:
        refuse_unread_settings(config, seed, settings="--episodes, --start-noise", reader="--from-sb3 or --planner (a rollout)")
    if planner:
        say_written(demos_stage.planner_demos(store(), env_id=env_id, config=config, seed=seed, name=name))
    elif bundled:
        say_written(demos_stage.import_bundled_demos(store(), env_id=env_id, name=name))
    elif from_sb3 is not None:
        say_written(demos_stage.import_sb3_demos(store(), env_id=env_id, model=from_sb3, config=config, seed=seed, name=name))
    else:
        say_written(demos_stage.import_demos(store(), env_id=env_id, name=name, minari_id=from_minari, npz=from_file, imitation=from_imitation))


# ------------------------------------------------------------------------------ LWAIL stages
@command(app, "pretrain-icvf", config=cfg.EmbedConfig)
def pretrain_icvf(
    data: str = typer.Argument(..., metavar="DATASET", help="Dataset artifact (from `lwail collect`)."),
    demos: Optional[str] = typer.Option(None, "--demos", metavar="REF", help="Expert demos: also probe expert-vs-random separation and progress in φ (recommended)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = resume_option(cfg.EmbedConfig, "pre-training"),
    *,
    config: cfg.EmbedConfig,
) -> None:
    """Pre-train the state embedding φ of --kind (ICVF by default; `lwail defaults pretrain-icvf` lists the kinds) on
    state-only data and report its quality probe."""
    unread = unread_settings(config)
    if unread:
        raise LwailError(f"--kind {config.kind} does not read {', '.join(unread)}; give its own settings as --set {config.kind}.FIELD=VALUE "
                         f"(see `lwail defaults pretrain-icvf`)")
    with progress_bar("pretrain-icvf", work("pretrain-icvf", config)) as report:
        artifact = embed_stage.embed(
            store(), data_ref=data, config=config, seed=seed, name=name, device=resolve_device(device), demos_ref=demos, on_progress=report,
            resume=resume,
        )
    say_written(artifact)


@command(app, "warmup-disc", config=cfg.WarmupConfig)
def warmup_disc(
    embedding: str = typer.Argument(..., metavar="EMBEDDING", help="Embedding artifact (from `lwail pretrain-icvf`)."),
    demos: str = typer.Argument(..., metavar="DEMOS", help="Demos artifact."),
    data: Optional[str] = typer.Option(None, "--data", metavar="REF", help="Random-policy dataset (default: the one the embedding was trained on)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    *,
    config: cfg.WarmupConfig,
) -> None:
    """Warm the discriminator f up: expert pairs vs the random policy's true (s, s') pairs."""
    with progress_bar("warmup-disc", config.steps) as report:
        artifact = warmup_stage.warmup(
            store(), embedding_ref=embedding, demos_ref=demos, config=config, seed=seed, name=name,
            device=resolve_device(device), data_ref=data, on_progress=report,
        )
    say_written(artifact)


@command(app, "imitate", config=cfg.ImitationConfig)
def imitate(
    env_id: str = typer.Argument(..., metavar="ENV_ID", help="Environment to imitate in."),
    demos: str = typer.Option(..., "--demos", metavar="REF", help="Demos artifact."),
    embedding: str = typer.Option(..., "--embedding", metavar="REF", help="Embedding artifact."),
    disc: Optional[str] = typer.Option(None, "--disc", metavar="REF", help="Warmed-up discriminator artifact, for --method lwail (f keeps the loss it was warmed up with)."),
    seed: int = SEED,
    name: Optional[str] = NAME,
    device: str = DEVICE,
    resume: bool = resume_option(cfg.ImitationConfig, "run"),
    *,
    config: cfg.ImitationConfig,
) -> None:
    """Imitate with TD3 on an imitation method's reward: LWAIL's σ(−f(φ(s), φ(s'))) (the default), GAIfO's or PWIL's; or with BCO's own loop."""
    with progress_bar(f"imitate {env_id}", config.train.steps, online_stage.budget_warnings(config)) as report:
        artifact = imitate_stage.imitate(
            store(), env_id=env_id, demos_ref=demos, embedding_ref=embedding, disc_ref=disc, config=config, seed=seed,
            name=name, device=resolve_device(device), resume=resume, on_progress=report,
        )
    say_written(artifact)
