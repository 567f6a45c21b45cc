"""The one exception type the CLI turns into a one-line message and a non-zero exit."""


class LwailError(Exception):
    """A problem with the user's input or the artifacts on disk, explained in one line."""
