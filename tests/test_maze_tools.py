"""What the maze experiments are run and shown with: the reward map, eval's maze scores, and the sweep plan's axis."""

from pathlib import Path

import numpy as np
import pytest
import torch

from lwail_cli import config as cfg
from lwail_cli.discriminator import Critic
from lwail_cli.errors import LwailError
from lwail_cli.mazes import MAZES
from lwail_cli.reward_map import reward_grid
from lwail_cli.stages.sweep_plan import grid_lines, plan_from_dict, read_plan

ENV = "PointMazeUMaze-v0"
PLANS = Path(__file__).resolve().parents[1] / "plans"


def test_the_reward_grid_follows_the_critic_and_blanks_the_walls():
    cells = MAZES["UMaze"].cells
    critic = Critic(2 * 4, (8,))
    xs, ys, reward = reward_grid(torch.nn.Identity(), critic.eval(), cells, per_cell=4)
    assert reward.shape == (len(ys), len(xs)) == (5 * 4, 5 * 4)
    wall = np.kron(np.asarray(cells), np.ones((4, 4))) == 1
    assert np.isnan(reward[wall]).all() and np.isfinite(reward[~wall]).all()
    assert ((0 < reward[~wall]) & (reward[~wall] < 1)).all() and reward[~wall].std() > 0  # σ of a critic that varies over (x, y)
    states = torch.tensor([[xs[5], ys[5], 0.0, 0.0]], dtype=torch.float32)  # row 5 = ys[5], column 5 = xs[5]: an open cell
    expected = torch.sigmoid(-critic(torch.cat([states, torch.zeros_like(states)], dim=-1))).item()
    assert reward[5, 5] == pytest.approx(expected, rel=1e-5)


def test_the_chain_runs_on_a_maze_and_draws_its_reward_map_and_scores(cli, store, tmp_path):
    assert cli("collect", ENV, "--transitions", "300", "--name", "data").exit_code == 0
    assert cli("demos", "import", ENV, "--bundled", "--name", "demos").exit_code == 0
    assert cli("pretrain-icvf", "data", "--steps", "2", "--embedding-dim", "8", "--set", "icvf.hidden=8", "--name", "phi").exit_code == 0
    assert cli("warmup-disc", "phi", "demos", "--set", "steps=2", "--name", "disc").exit_code == 0
    drawn = cli("reward-map", "disc", "--per-cell", "4", "--out", tmp_path / "map.png")
    assert drawn.exit_code == 0, drawn.output
    assert (tmp_path / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    result = cli("imitate", ENV, "--demos", "demos", "--embedding", "phi", "--disc", "disc", "--steps", "300", "--name", "run",
                 "--set", "td3.random_steps=100", "--set", "td3.learning_starts=256", "--eval-every", "300", "--set", "train.eval_episodes=2",
                 "--start-noise", "0.2")
    assert result.exit_code == 0, result.output
    policy = store.resolve("run", "policy")
    assert policy.config["env"] == {"start_noise": 0.2}
    assert cli("reward-map", "run").output.strip() == f"wrote {policy.path / 'reward-map.png'}"  # its kept critic, beside it
    scored = cli("eval", "run", "--normalized", "--episodes", "2", "--start-noise", "0.5")
    assert scored.exit_code == 0, scored.output
    assert "success rate" in scored.output and "maze2d-umaze-dense" in scored.output and "% of our expert" in scored.output
    assert "(start noise 0.5)" in scored.output
    refused = cli("reward-map", "data")
    assert refused.exit_code != 0 and "draws a discriminator or an imitation policy" in refused.output


def test_reward_map_refuses_a_task_without_a_maze(cli, store, tmp_path):
    np.savez(tmp_path / "d.npz", observations=np.random.default_rng(0).normal(size=(40, 4)).astype(np.float32),
             episode_ends=np.arange(40) % 20 == 19)
    assert cli("collect", "InvertedPendulum-v5", "--from-file", tmp_path / "d.npz", "--name", "ip").exit_code == 0
    assert cli("demos", "import", "InvertedPendulum-v5", "--bundled", "--name", "ipd").exit_code == 0
    assert cli("pretrain-icvf", "ip", "--kind", "identity", "--name", "ident").exit_code == 0
    assert cli("warmup-disc", "ident", "ipd", "--set", "steps=2", "--name", "ipdisc").exit_code == 0
    refused = cli("reward-map", "ipdisc")
    assert refused.exit_code != 0 and "reward-map draws the PointMaze tasks" in refused.output


def noise_plan(**axis) -> dict:
    return {"name": "noise", "tasks": [ENV], "seeds": [0], "embeddings": ["icvf", "identity"], "labels": {"icvf": "LWAIL"},
            "axis": {"setting": "env.start_noise", "name": "noise", "values": [0.0, 0.2, 0.5], **axis}}


def test_an_axis_makes_each_arm_one_arm_per_value_with_the_setting_where_a_stage_has_it():
    plan = plan_from_dict(noise_plan(), "plan")
    assert [run.kind for run in plan.runs] == ["icvf-noise0.0", "icvf-noise0.2", "icvf-noise0.5",
                                               "identity-noise0.0", "identity-noise0.2", "identity-noise0.5"]
    assert plan.embedding_kind("identity-noise0.5") == "identity" and plan.label("icvf-noise0.2") == "LWAIL, noise 0.2"
    assert plan.config("imitate", "icvf-noise0.5").env.start_noise == 0.5 == plan.config("eval", "identity-noise0.5").env.start_noise
    assert plan.config("collect").env.start_noise == 0.0  # data set I is shared by the arms of a seed
    assert plan.config("pretrain-icvf", "icvf-noise0.5").kind == "icvf"
    assert plan_from_dict(plan.to_dict(), "again") == plan  # workers and reports re-read it: no axis twice
    assert len({plan.names(run)["policy"] for run in plan.runs}) == 6


@pytest.mark.parametrize(("axis", "message"), [
    ({"setting": "env.no_such"}, "no stage after collect has the setting 'env.no_such'"),
    ({"setting": "env"}, "no stage after collect has the setting 'env'"),  # a section, not a setting
    ({"values": []}, "'values' be a non-empty list"),
    ({"values": [-0.5]}, "env.start_noise must be at least 0"),
    ({"colour": "red"}, "needs setting"),
])
def test_a_bad_axis_is_refused_in_one_line(axis, message):
    with pytest.raises(LwailError, match=message):
        plan_from_dict(noise_plan(**axis), "plan")


def test_the_noise_plan_reads_and_its_dry_run_prints_the_grid_without_running(cli, store):
    plan = read_plan(PLANS / "pointmaze-noise.toml")
    assert len(plan.runs) == 6 and plan.tasks == ["PointMazeMedium-v0"] and plan.config("imitate", "icvf-noise0.5").train.steps == 500_000
    assert {plan.config("imitate", run.kind).env.start_noise for run in plan.runs} == {0.0, 0.2, 0.5}
    printed = cli("sweep", "--dry-run", PLANS / "pointmaze-noise.toml")
    assert printed.exit_code == 0, printed.output
    assert "6 runs" in printed.output and printed.output.count("env.start_noise=") == 12  # imitate and eval of each run
    assert printed.output.strip().splitlines()[1:] == grid_lines(plan)
    assert not store.root.exists() or not any(store.root.iterdir())  # nothing ran
    assert cfg.with_overrides(cfg.ImitationConfig(), ["env.start_noise=0.5"]).env.start_noise == 0.5


def test_a_log_row_with_new_columns_extends_an_older_file_and_keeps_its_rows(store):
    import pandas as pd

    from lwail_cli.stages.demos import import_bundled_demos

    artifact = import_bundled_demos(store, env_id="InvertedPendulum-v5")
    artifact.append_log("evals.csv", {"created": "then", "return_mean": 1.0})  # as an older lwail wrote it
    artifact.append_log("evals.csv", {"created": "now", "return_mean": 2.0, "success_rate": 0.5})
    artifact.append_log("evals.csv", {"return_mean": 3.0, "created": "later"})  # fewer columns, another order
    rows = pd.read_csv(artifact.beside("evals.csv"))
    assert list(rows.columns) == ["created", "return_mean", "success_rate"]
    assert list(rows["return_mean"]) == [1.0, 2.0, 3.0] and rows["success_rate"].isna().tolist() == [True, False, True]
