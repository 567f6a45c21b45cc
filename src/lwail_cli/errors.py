"""The one exception type the CLI turns into a one-line message and a non-zero exit."""


class LwailError(Exception):
    """A problem with the user's input or the artifacts on disk, explained in one line."""


class RunPaused(LwailError):
    """A run that checkpointed and stopped because it was asked to (`lwail pause`, or SIGTERM)."""

    def __init__(self, step: int):
        super().__init__(f"paused at step {step} as asked, its checkpoint kept: the same command with --resume continues it "
                         "(a sweep's run: run the sweep again)")
        self.step = step

    def __reduce__(self):  # rebuilt from its step, not its message (Ray hands a task's error back to the sweep so)
        return RunPaused, (self.step,)
