"""Independent random streams from one seed.

A run's seed names one stream per use: the random data set I (``collect``), the online run's environment,
random actions and exploration noise (``online``), and the evaluation episodes (``evaluation``). Each is
derived with numpy's ``SeedSequence`` from (seed, use), so the online run of seed 0 does not replay data set I
of seed 0, and runs of different seeds never play the same evaluation episodes (as ``seed + i`` would).
"""

from __future__ import annotations

import numpy as np

STREAMS = ("collect", "online", "evaluation")  # append only: an index names a stream in every result so far


def stream_seeds(seed: int, stream: str, count: int = 1) -> list[int]:
    """``count`` seeds (each below 2**32) of ``stream`` under ``seed``; the first k do not depend on ``count``."""
    return [int(word) for word in np.random.SeedSequence([seed, STREAMS.index(stream)]).generate_state(count)]
