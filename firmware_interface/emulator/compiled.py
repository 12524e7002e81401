"""The emulator's flight code as one group of compiled code (`firmware_interface.compiled_code`).

Why compiled: the estimator, the control laws and the mixer are a few hundred operations on 3- and 4-vectors per
step; numpy spends ~1 µs on each, so a step cost ~100 µs of interpreter work. numba compiles the same Python
source (the paper's equations stay as written) into native code: one definition of each law, no C twin.

- `flight_code`: a step the emulator calls from Python (an estimator update, a control law, the mixer).
- `shared_maths`: a formula both sides use (quaternions, Euler rates, C(η, η̇)): plain Python when the
  bench calls it, compiled into the flight code that calls it.

The group's sources are the whole emulator package and the modules of the frames it packs, so a change anywhere
in them compiles afresh.
"""

from __future__ import annotations

from pathlib import Path

from firmware_interface import compiled_code, geodesy, hil_frames
from firmware_interface.compiled_code import CompiledCode
from firmware_interface.link import frame_packing

FLIGHT_CODE = CompiledCode("flight-code", (Path(__file__).resolve().parent, Path(compiled_code.__file__),
                                           Path(frame_packing.__file__), Path(hil_frames.__file__),
                                           Path(geodesy.__file__)))
flight_code = FLIGHT_CODE.compiled
shared_maths = CompiledCode.inline
