import pytest

from lwail_cli.evaluation import D4RL_REFERENCES, Reference, d4rl_reference


def test_d4rl_normalization_arithmetic():
    hopper = d4rl_reference("Hopper-v5")
    assert hopper.normalize(3234.3) == pytest.approx(100.0)
    assert hopper.normalize(-20.272305) == pytest.approx(0.0)
    assert hopper.normalize((3234.3 - 20.272305) / 2) == pytest.approx(50.0)
    # the paper's expert Hopper score 113.23 corresponds to a return of ~3665
    assert hopper.normalize(-20.272305 + 1.1323 * (3234.3 + 20.272305)) == pytest.approx(113.23)


@pytest.mark.parametrize("env_id, family, published", [  # D4RL's REF_MIN_SCORE / REF_MAX_SCORE (d4rl/infos.py)
    ("HalfCheetah-v5", "halfcheetah", (-280.178953, 12135.0)), ("Walker2d-v5", "walker2d", (1.629008, 4592.3)),
    ("Ant-v5", "ant", (-325.6, 3879.7)), ("PointMazeUMazeSparse-v0", "maze2d-umaze", (23.85, 161.86)), ("PointMazeMedium-v0", "maze2d-medium-dense", (44.264742, 297.4552547777125))])
def test_d4rl_families_map_to_their_reference_values(env_id, family, published):
    low, high = D4RL_REFERENCES[family]
    reference = d4rl_reference(env_id)
    assert (reference.random_return, reference.expert_return) == (low, high) == published
    assert family in reference.source
    assert reference.normalize(published[1]) == pytest.approx(100.0) and reference.normalize(published[0]) == pytest.approx(0.0)


def test_tasks_without_d4rl_values_get_none_and_custom_references_work():
    assert d4rl_reference("InvertedPendulum-v5") is None
    assert Reference(5.0, 1005.0, "demos").normalize(505.0) == pytest.approx(50.0)
