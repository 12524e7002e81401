"""Standard normal draws in blocks (one numpy call per BLOCK rows), read row by row by the compiled sensor models,
and the compiled code group the models belong to.

A sensor's draws come from its own generator, block after block in the same order whenever they are drawn, so
the noise of a seed is the same however often the rows are taken.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from firmware_interface import compiled_code, geodesy, hil_frames
from firmware_interface.compiled_code import CompiledCode
from firmware_interface.link import frame_packing

BLOCK = 256  # ~0.1 ms to refill: a paced step absorbs it (4096 rows took 1.5 ms, a late step)
# the sensor models, and what they compile in: the packing of their readings (hil/loop's step goes on to the bytes)
SENSORS = CompiledCode("sensors", (Path(__file__).parent, Path(hil_frames.__file__), Path(frame_packing.__file__),
                                   Path(geodesy.__file__), Path(compiled_code.__file__)))


class NormalStream:
    """Rows of `width` independent N(0, 1) draws from one seeded generator: `rows` holds the current block and
    `cursor[0]` the next row to take (compiled code takes it and advances the cursor; `refill` draws the next block
    once the last row is taken)."""

    def __init__(self, rng: np.random.Generator, width: int) -> None:
        self._rng = rng
        self.rows = np.empty((BLOCK, width))
        self.cursor = np.full(1, BLOCK, dtype=np.int64)

    def refill(self) -> None:
        if self.cursor[0] == BLOCK:
            self.rows[:] = self._rng.standard_normal(self.rows.shape)
            self.cursor[0] = 0
