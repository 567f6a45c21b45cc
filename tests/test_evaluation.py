import pytest

from lwail_cli.evaluation import D4RL_REFERENCES, Reference, d4rl_reference


def test_d4rl_normalization_arithmetic():
    hopper = d4rl_reference("Hopper-v5")
    assert hopper.normalize(3234.3) == pytest.approx(100.0)
    assert hopper.normalize(-20.272305) == pytest.approx(0.0)
    assert hopper.normalize((3234.3 - 20.272305) / 2) == pytest.approx(50.0)
    # the paper's expert Hopper score 113.23 corresponds to a return of ~3665
    assert hopper.normalize(-20.272305 + 1.1323 * (3234.3 + 20.272305)) == pytest.approx(113.23)


@pytest.mark.parametrize("env_id, family", [("HalfCheetah-v5", "halfcheetah"), ("Walker2d-v5", "walker2d"), ("Ant-v5", "ant"), ("PointMaze_UMaze-v3", "maze2d-umaze")])
def test_d4rl_families_map_to_their_reference_values(env_id, family):
    low, high = D4RL_REFERENCES[family]
    reference = d4rl_reference(env_id)
    assert (reference.random_return, reference.expert_return) == (low, high)
    assert family in reference.source


def test_tasks_without_d4rl_values_get_none_and_custom_references_work():
    assert d4rl_reference("InvertedPendulum-v5") is None
    assert Reference(5.0, 1005.0, "demos").normalize(505.0) == pytest.approx(50.0)
