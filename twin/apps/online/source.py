"""Where the online compensator's F/T sample comes from when the robot's packet does not carry it.

A KUKA RSI packet can carry the forces (the cell's RSI diagram reads the sensor); an ABB EGM or a Stäubli VAL3
`alter` cell usually reads the sensor on the PC instead, from the sensor's own stream (ATI Net F/T RDT,
`twin.apps.online.rdt`). A server asks its `ForceSource` for the latest sample once per cycle, without waiting.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class ForceSource(Protocol):
    """The latest F/T sample, read without blocking.

    Attributes:
        force_n: The latest force, sheet frame [N], shape (3,); updated in place by `poll`.
        stamp_s: When it was measured, on the server's clock (`time.perf_counter`) [s]; NaN before a first sample.
    """

    force_n: np.ndarray
    stamp_s: float

    def poll(self) -> int:
        """Read every sample waiting (none: return at once); returns how many were read."""
        ...

    def close(self) -> None:
        """Stop the stream and release the socket."""
        ...
