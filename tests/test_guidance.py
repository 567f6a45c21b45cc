"""What lwail tells a user beside the result: a warning for a budget that cannot train or be watched, the next
commands after quickstart, where figures go, what an import found, what a metric means, and help that reads at 80
columns."""

import pytest

TINY_TD3 = ("--set", "td3.hidden=8", "--set", "td3.batch_size=16", "--set", "train.eval_episodes=1")


@pytest.mark.parametrize(
    "budget, warnings",
    [
        (("--steps", "60", "--eval-every", "60", "--set", "td3.learning_starts=16"),
         ["--steps 60 is at most td3.random_steps (10000): every action is uniformly random, the policy kept never acted"]),
        (("--steps", "10", "--eval-every", "10", "--set", "td3.learning_starts=16"),
         ["--steps 10 is below td3.learning_starts (16): TD3 never updates, the policy kept is its untrained initial network"]),
        (("--steps", "60", "--eval-every", "100", "--set", "td3.learning_starts=16", "--set", "td3.random_steps=20"),
         ["--eval-every 100 is above --steps 60: the policy is evaluated once, at the end"]),
        (("--steps", "60", "--eval-every", "30", "--set", "td3.learning_starts=16", "--set", "td3.random_steps=20"), []),
    ],
)
def test_a_budget_that_cannot_train_or_be_watched_is_warned_and_still_runs(cli, store, budget, warnings):
    result = cli("expert", "train", "InvertedPendulum-v5", *budget, *TINY_TD3)
    assert result.exit_code == 0, result.output
    shown = [line for line in result.output.splitlines() if line.startswith("warning: ")]
    assert len(shown) == len(warnings) and all(line.startswith(f"warning: {w}") for line, w in zip(shown, warnings)), shown
    assert store.resolve("invertedpendulum-v5-expert", "policy").metrics["env_steps"] == int(budget[1])
