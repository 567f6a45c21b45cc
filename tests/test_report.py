"""`lwail report`: a run's figures, the IQM and its stratified-bootstrap interval, the performance profile, and the
report rebuilt from committed curve files alone (`--curves`)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("scipy")

PLAN = '''name = "tiny"
tasks = ["InvertedPendulum-v5"]
seeds = [0, 1]
embeddings = ["icvf", "identity"]
[set]
imitate = ["train.steps=1000"]
[labels]
identity = "no embedding"
'''


def test_a_runs_figures_are_defined_once_from_its_curve():
    from lwail_cli.learning_curve import curve_figures

    # 10 evaluations of a 1,000-step run; a dip at 700 (second half) and a worse one at 300 (first half)
    scores = [5.0, 20.0, 10.0, 60.0, 80.0, 90.0, 40.0, 95.0, 100.0, 98.0]
    curve = pd.DataFrame({"step": range(100, 1001, 100), "normalized_score": scores})
    assert curve_figures(curve, 1000) == {"at_end": 98.0, "last_10pct_mean": 98.0, "second_half_mean": 84.6,
                                          "second_half_min": 40.0, "best": 100.0, "second_half_min_step": 700.0,
                                          "best_step": 900.0}
    # "the last 10%" is the evaluations after step 0.9·N: of a 2,000-step curve, the mean of 1,900 and 2,000
    longer = pd.DataFrame({"step": range(100, 2001, 100), "normalized_score": range(20)})
    assert curve_figures(longer, 2000)["last_10pct_mean"] == 18.5


def test_the_iqm_of_a_known_table_and_its_interval():
    from lwail_cli import statistics

    # two tasks of four runs: the IQM drops the lowest and highest quarter of the eight, 1, 2 and 7, 8
    by_task = [np.array([1.0, 2.0, 3.0, 4.0]), np.array([5.0, 6.0, 7.0, 8.0])]
    assert statistics.pooled_iqm(by_task) == 4.5
    assert statistics.pooled_iqm([np.array([1.0, 2.0, 30.0])]) == 11.0  # of three runs: their mean
    low, high = statistics.iqm_interval(by_task)
    assert low < 4.5 < high and (low, high) == statistics.iqm_interval(by_task)  # a fixed bootstrap seed
    # each task resampled on its own: no resample mixes the tasks' runs, so the IQM can never fall to task 1's level
    assert low > 2.5 and high < 6.5
    assert all(np.isnan(statistics.iqm_interval([np.array([1.0, 2.0]), np.array([5.0])])))  # one run cannot be resampled

    draws = np.random.default_rng(1).normal(50.0, 10.0, size=40)
    few, many = statistics.iqm_interval([draws[:5]]), statistics.iqm_interval([draws])
    assert many[1] - many[0] < few[1] - few[0]  # more seeds, a narrower interval


def test_one_arm_against_another_a_known_difference_interval_and_probability_of_improvement():
    from lwail_cli import statistics

    x, y = np.array([3.0, 4.0, 5.0]), np.array([1.0, 2.0, 4.0])
    # 7 of the 9 pairs have x above, one tie counts half
    assert statistics.probability_of_improvement(x, y) == pytest.approx(7.5 / 9)
    # Welch: difference 5/3, standard error √(1/3 + 7/9), 3.45 degrees of freedom
    assert statistics.mean_difference_interval(x, y) == pytest.approx((-1.454, 4.788), abs=1e-3)
    assert all(np.isnan(statistics.mean_difference_interval(x, y[:1])))  # one run: no interval
    # across tasks each task weighs the same: a task won in every pair and one lost in every pair average to a half
    # (no resample changes either order, so the interval is a point)
    assert statistics.mean_probability_of_improvement([(x + 10, y), (x, y + 10)]) == (0.5, 0.5, 0.5)
    p, low, high = statistics.mean_probability_of_improvement([(x, y)])  # resamples of overlapping runs spread it
    assert p == pytest.approx(7.5 / 9) and 0.3 < low < p and high == 1.0


def test_the_first_arm_against_the_other_separates_where_its_interval_excludes_zero():
    import tomllib

    from lwail_cli.stages.report_tables import RunCurve, markdown, tables
    from lwail_cli.stages.sweep_plan import plan_from_dict

    text = PLAN.replace("seeds = [0, 1]", "seeds = [0, 1, 2]").replace('tasks = ["InvertedPendulum-v5"]', 'tasks = ["InvertedPendulum-v5", "Hopper-v5"]')
    plan = plan_from_dict(tomllib.loads(text), "test plan")
    scores = {("InvertedPendulum-v5", "icvf"): [90, 95, 100], ("InvertedPendulum-v5", "identity"): [40, 50, 60],
              ("Hopper-v5", "icvf"): [50, 60, 70], ("Hopper-v5", "identity"): [55, 65, 45]}

    def curve(score):
        return pd.DataFrame({"step": range(100, 1001, 100), "wall_time": 60.0, "return_mean": 2.0 * score, "normalized_score": float(score)})

    curves = [RunCurve(run, curve(scores[run.task, run.arm][run.seed]), 200.0, "test") for run in plan.runs]
    lines = markdown(tables(plan, curves)).splitlines()
    rows = {line.split(" | ")[0].lstrip("| "): line for line in lines if "| no embedding | 3 vs 3 |" in line or "| 6 vs 6 |" in line}
    # InvertedPendulum: 95 − 50 with Welch's interval (variances 25 and 100, 2.94 degrees of freedom); won in all 9 pairs
    assert rows["InvertedPendulum-v5"].startswith("| InvertedPendulum-v5 | no embedding | 3 vs 3 | +45.0 [24.")
    assert rows["InvertedPendulum-v5"].endswith("| 1.00 [1.00, 1.00] | first higher |")
    # Hopper: 60 − 55, an interval across 0; 6 of 9 pairs won
    assert " | +5.0 [-" in rows["Hopper-v5"] and rows["Hopper-v5"].endswith("| no |") and "| 0.67 [" in rows["Hopper-v5"]
    assert "| all tasks | no embedding | 6 vs 6 | — | — | 0.83 [" in rows["all tasks"]
    # the title names the first arm even where another arm's runs come first in the tables
    later = [entry for entry in curves if (entry.run.task, entry.run.arm) != ("InvertedPendulum-v5", "icvf")]
    assert "**icvf against each other arm**" in markdown(tables(plan, later))


def test_a_performance_profile_counts_the_runs_above_each_threshold_each_task_weighing_the_same():
    from lwail_cli import statistics

    by_task = [np.array([10.0, 30.0]), np.array([50.0, 70.0, 90.0, 110.0])]
    profile, low, high = statistics.performance_profile(by_task, np.array([0.0, 20.0, 60.0, 100.0, 120.0]))
    np.testing.assert_allclose(profile, [1.0, 0.75, 0.375, 0.125, 0.0])
    assert (low <= profile).all() and (profile <= high).all() and low[1] < high[1]


def _write_curve(path: Path, scores, fell=()):
    steps = list(range(100, 100 * len(scores) + 1, 100))
    pd.DataFrame({"step": steps, "wall_time": [s / 10 for s in steps], "return_mean": [10.0 * s for s in scores],
                  "normalized_score": scores, "episodes_terminated": [int(step in fell) for step in steps]}).to_csv(path, index=False)


def test_the_report_is_rebuilt_from_committed_curve_files(cli, tmp_path):
    plan, curves, out = tmp_path / "tiny.toml", tmp_path / "results", tmp_path / "figures"
    plan.write_text(PLAN)
    curves.mkdir()
    ramp = [10.0 * i for i in range(1, 9)]
    _write_curve(curves / "tiny_invertedpendulum-v5_icvf_seed0.csv", ramp + [80.0, 90.0], fell=(700,))
    _write_curve(curves / "tiny_invertedpendulum-v5_icvf_seed1.csv", ramp + [60.0, 70.0])
    _write_curve(curves / "tiny_invertedpendulum-v5_identity_seed0.csv", ramp + [40.0, 50.0])
    _write_curve(curves / "tiny_invertedpendulum-v5_identity_seed1.csv", ramp)  # to step 800 of 1,000: not finished
    _write_curve(curves / "other_invertedpendulum-v5_identity_seed1.csv", [1.0] * 10)  # another plan's
    result = cli("report", plan, "--curves", curves, "--out", out)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    # icvf: the last 10% (step > 900) and the end are 90 and 70; after half (600..1000) means 76 and 68, lowest 60
    assert "| InvertedPendulum-v5 | icvf | 2 | 80.0 ± 14.1 | 80.0 [70.0, 90.0] | 80.0 ± 14.1 | 72.0 ± 5.7 | 60.0 | 2 min, 10 | — |" in lines
    assert "| InvertedPendulum-v5 | no embedding | 1 | 50.0 | 50.0 | 50.0 | 60.0 | 40.0 | 2 min, 10 | — |" in lines  # one seed: no interval
    # % of the bundled expert's 1,000: the curve's returns are 10 × the score
    assert "| InvertedPendulum-v5 | icvf | 2 | 1,000 | 80.0 ± 14.1 | 80.0 [70.0, 90.0] | 70.0 | 80.0 ± 14.1 | 72.0 ± 5.7 |" in lines
    assert "| InvertedPendulum-v5 | icvf | 0 | 90.0 | 90.0 | 76.0 | 60.0 (600) | 90.0 (1k) | 1 of 5 | 90.0 | 2 min, 10 |" in lines
    assert "| icvf | 1 | 2 | 80.0 [70.0, 90.0] | 80.0 [70.0, 90.0] |" in lines and "| no embedding | 1 | 1 | 50.0 | 50.0 |" in lines
    # icvf against the identity's one finished seed: a difference and P, no interval, no verdict
    assert "| InvertedPendulum-v5 | no embedding | 2 vs 1 | +30.0 | +30.0 | 1.00 | — |" in lines
    assert sorted(path.name for path in out.iterdir()) == ["tiny_invertedpendulum-v5_curves.png", "tiny_profile.png"]


@pytest.mark.parametrize("setup, message", [
    (lambda folder: None, "holds no curve of plan tiny that reached its last step (looked for tiny_<task>_<arm>_seed<S>.csv"),
    (lambda folder: _write_curve(folder / "other_invertedpendulum-v5_icvf_seed0.csv", [1.0] * 10), "holds no curve of plan tiny"),
])
def test_a_folder_without_the_plans_curves_is_one_clear_line(cli, tmp_path, setup, message):
    plan, curves = tmp_path / "tiny.toml", tmp_path / "results"
    plan.write_text(PLAN)
    curves.mkdir()
    setup(curves)
    result = cli("report", plan, "--curves", curves)
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert cli("report", "tiny", "--curves", curves).output.count("give the plan file") == 1


@pytest.mark.parametrize("curves", [False, True])
def test_a_misspelt_plan_file_is_named_as_a_missing_file_not_as_a_missing_report(cli, store, tmp_path, curves):
    result = cli("report", tmp_path / "tny.toml", *(["--curves", tmp_path] if curves else []))
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert f"no plan file {tmp_path / 'tny.toml'}" in result.output and "report artifact" not in result.output


RUNNING_PLAN = PLAN.replace("seeds = [0, 1]", "seeds = [0]").replace("train.steps=1000", "train.steps=10000")


def _write_running_curve(path: Path, evaluations: int):
    """Evaluations every 500 steps scoring 1, 2, 3, ... (returns 10 x the score)."""
    scores = [float(i) for i in range(1, evaluations + 1)]
    pd.DataFrame({"step": [500 * i for i in range(1, evaluations + 1)], "return_mean": [10.0 * s for s in scores],
                  "normalized_score": scores}).to_csv(path, index=False)


@pytest.mark.parametrize("finished", [True, False])
def test_an_unfinished_run_is_shown_where_its_furthest_curve_stands_and_never_counted(cli, tmp_path, finished):
    plan, curves = tmp_path / "tiny.toml", tmp_path / "results"
    plan.write_text(RUNNING_PLAN)
    curves.mkdir()
    if finished:
        _write_running_curve(curves / "tiny_invertedpendulum-v5_icvf_seed0.csv", 20)
    _write_running_curve(curves / "tiny_invertedpendulum-v5_identity_seed0_to3k.csv", 6)
    _write_running_curve(curves / "tiny_invertedpendulum-v5_identity_seed0_to5k.csv", 10)  # the same run, further
    result = cli("report", plan, "--curves", curves, "--out", tmp_path / "figures")
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    # to step 5,000 of 10,000: latest 10; recent = the evaluations after 4,000 (the last 10% of the plan's steps): 9.5,
    # 95 of the bundled expert's 1,000 = 9.5%; no Wasserstein estimate: no probe
    assert "| InvertedPendulum-v5 | no embedding | 0 | 5k of 10k | 10.0 | 9.5 | 9.5 | 10.0 (5k) | — | `tiny_invertedpendulum-v5_identity_seed0_to5k.csv` |" in lines
    assert sum("| no embedding |" in line for line in lines) == 1  # in no statistics table
    assert ("| InvertedPendulum-v5 | icvf | 1 | 19.5 | 19.5 | 20.0 |" in result.output) is finished  # the finished run: reported as before
    assert ("reached its last step" in result.output) is not finished


def test_a_running_sweeps_runs_are_shown_from_the_store_before_any_has_finished(cli, store, tmp_path):
    from lwail_cli.stages.sweep_plan import read_plan

    plan_file = tmp_path / "tiny.toml"
    plan_file.write_text(RUNNING_PLAN)
    plan = read_plan(plan_file)
    name = plan.names(plan.runs[0])["policy"]
    rows = [{"step": 500 * i, "return_mean": 10.0 * i, "normalized_score": float(i), "wasserstein_estimate": 1.99} for i in range(1, 5)]
    store.runs.write_run_log("policy", name, "learning_curve.csv", rows)
    result = cli("report", plan_file)
    assert result.exit_code == 0, result.output
    assert "no run of sweep tiny has finished yet: no report written" in result.output
    # no demos in the store: no % of our expert; at 2k of 10k the critic is not judged yet (the probe reads 150k)
    assert "| InvertedPendulum-v5 | icvf | 0 | 2k of 10k | 4.0 | 3.5 | — | 4.0 (2k) | — |" in result.output


def test_a_plans_labels_name_its_arms_and_are_checked(tmp_path):
    import tomllib

    from lwail_cli.errors import LwailError
    from lwail_cli.stages.sweep_plan import plan_from_dict

    plan = plan_from_dict(tomllib.loads(PLAN), "test plan")
    assert (plan.label("identity"), plan.label("icvf")) == ("no embedding", "icvf")
    assert plan_from_dict(plan.to_dict(), "a report's record") == plan
    with pytest.raises(LwailError, match=r"\[labels\] names \['pca'\], which are not arms"):
        plan_from_dict(tomllib.loads(PLAN.replace("identity = ", "pca = ")), "test plan")
    with pytest.raises(LwailError, match="non-empty public names"):
        plan_from_dict(tomllib.loads(PLAN.replace('"no embedding"', '""')), "test plan")


def test_the_papers_figure_is_an_arms_embedding_kinds_and_demos_without_returns_have_no_percentage():
    import tomllib

    from lwail_cli.stages.report_tables import RunCurve, markdown, tables
    from lwail_cli.stages.sweep_plan import SweepRun, plan_from_dict

    plan = plan_from_dict(tomllib.loads(PLAN.replace("InvertedPendulum-v5", "Walker2d-v5").replace('"icvf", "identity"', '"icvf-authors", "identity"')
                                        + '[variants.icvf-authors]\nkind = "icvf"\n'), "test plan")
    curve = pd.DataFrame({"step": range(100, 1001, 100), "wall_time": 60.0, "return_mean": 1.0, "normalized_score": 50.0})
    curves = [RunCurve(SweepRun("Walker2d-v5", seed, arm), curve, float("nan"), "test") for arm in ("icvf-authors", "identity") for seed in (0, 1)]
    lines = markdown(tables(plan, curves)).splitlines()
    # a variant of icvf is compared with the paper's LWAIL, the identity with its no-embedding figure
    assert lines[4].startswith("| Walker2d-v5 | icvf-authors | 2 | 50.0 ± 0.0 | 50.0 [50.0, 50.0] |") and lines[4].endswith("| 106.5 ± 1.1 |")
    assert lines[5].startswith("| Walker2d-v5 | no embedding | 2 |") and lines[5].endswith("| 62.4 ± 20.4 |")
    assert "| Walker2d-v5 | no embedding | 2 | — | — | — | — | — | — |" in lines  # no expert return: no % of it


def test_a_plan_of_methods_reports_each_arm_and_method_and_names_each_ones_reward(tmp_path, monkeypatch):
    """The report's rows are task × embedding arm × method, each labelled with its method where the plan has several;
    the critic figure's legends say each method's reward (its registry entry's), never σ(−f) for all."""
    import tomllib

    from lwail_cli import plots
    from lwail_cli.methods import METHODS
    from lwail_cli.stages.report import draw
    from lwail_cli.stages.report_tables import RunCurve, tables
    from lwail_cli.stages.sweep_plan import plan_from_dict

    text = PLAN.split("[labels]")[0].replace('embeddings = ["icvf", "identity"]', 'embeddings = ["icvf"]\nmethods = ["lwail", "pwil"]')
    plan = plan_from_dict(tomllib.loads(text), "test plan")
    curve = pd.DataFrame({"step": range(100, 1001, 100), "wall_time": 60.0, "return_mean": 1.0, "normalized_score": 50.0,
                          "reward_expert_mean": 0.9, "pseudo_reward_mean": 0.5})
    curves = [RunCurve(run, curve.assign(normalized_score=50.0 + 10 * (run.method == "pwil")), 2.0, "test") for run in plan.runs]
    runs, summary, across, _ = tables(plan, curves)
    assert list(zip(summary["arm"], summary["method"], summary["label"])) == [("icvf-lwail", "lwail", "icvf, LWAIL"), ("icvf-pwil", "pwil", "icvf, PWIL")]
    assert list(summary["last_10pct_mean_mean"]) == [50.0, 60.0] and list(across["arm"]) == ["icvf-lwail", "icvf-pwil"]

    legends = []

    def keep(fig, path):
        legends.extend(text.get_text() for ax in fig.axes if ax.get_legend() for text in ax.get_legend().get_texts())
        plots._pyplot().close(fig)

    monkeypatch.setattr(plots, "_save", keep)
    draw(plan, curves, runs, lambda name: tmp_path / name)
    for method in ("lwail", "pwil"):
        assert f"{METHODS[method].reward} on expert pairs" in legends
    assert "σ(−f) on expert pairs" in legends and legends.count("σ(−f) on the latest policy pairs") == 1


def test_a_runs_figure_names_its_methods_reward(tmp_path, monkeypatch):
    from lwail_cli import plots
    from lwail_cli.methods import METHODS

    texts = []

    def keep(fig, path):
        for ax in fig.axes:
            texts.extend([ax.get_xlabel(), *(text.get_text() for text in (ax.get_legend().get_texts() if ax.get_legend() else []))])
        plots._pyplot().close(fig)

    monkeypatch.setattr(plots, "_save", keep)
    curve = pd.DataFrame({"step": [100, 200], "return_mean": [1.0, 2.0], "reward_expert_mean": [3.0, 4.0], "pseudo_reward_mean": [1.0, 2.0]})
    plots.plot_run(curve, tmp_path / "curve.png", tmp_path / "scatter.png", "GAIfO on a task", METHODS["gaifo"].reward)
    assert {"−log(1 − D) on expert pairs", "−log(1 − D) on the latest policy pairs", "mean −log(1 − D) of recent transitions"} <= set(texts)
    assert not any("σ(−f)" in text for text in texts)
