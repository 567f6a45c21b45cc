"""Readers and writers of file formats, one module each: Minari's hdf5, ``.npz``, the ``imitation`` library's
trajectories, and SB3's ``model.zip``.

They take and return paths and data (``list[data.Episode]``, weights), never touch the store, and run no code
from a file: nothing is unpickled (``allow_pickle=False``, ``torch.load(..., weights_only=True)``) and no env is
rebuilt from a recorded spec. A malformed file is refused with one ``LwailError`` line naming it.
"""
