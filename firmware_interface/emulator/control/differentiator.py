"""A third-order linear tracking differentiator: filtered signal, first and second derivatives.

ż1 = z2, ż2 = z3, ż3 = ω³(v − z1) − 3ω² z2 − 3ω z3: a triple pole at −ω. The paper asks for a
third-order differentiator for the commanded angles' derivatives without saying which; this
one has no chattering and one tuning knob, the bandwidth ω. It is stepped exactly (zero-order
hold on v): z ← A_d z + B_d v, with A_d = exp(A dt) computed once per step size.
"""

from __future__ import annotations

import numpy as np

from firmware_interface.emulator.compiled import flight_code


def _expm(a: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring of a Taylor series (3x3, well-conditioned here)."""
    norm = float(np.abs(a).sum(axis=1).max())
    squarings = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    scaled = a / 2**squarings
    result, term = np.eye(len(a)), np.eye(len(a))
    for k in range(1, 14):
        term = term @ scaled / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


@flight_code
def step_exact(a_d: np.ndarray, b_d: np.ndarray, z: np.ndarray, v: np.ndarray) -> None:
    """z ← A_d z + B_d vᵀ in place (each column of z one channel)."""
    for channel in range(z.shape[1]):
        value, first, second = z[0, channel], z[1, channel], z[2, channel]
        for row in range(3):
            z[row, channel] = (a_d[row, 0] * value + a_d[row, 1] * first + a_d[row, 2] * second
                               + b_d[row] * v[channel])


class ThirdOrderDifferentiator:
    def __init__(self, bandwidth_rad_s: float, size: int = 3) -> None:
        w = bandwidth_rad_s
        self.w = w
        self._a = np.array(((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (-(w**3), -3 * w**2, -3 * w)))
        self._b = np.array((0.0, 0.0, w**3))
        self._dt = -1.0
        self._ad = np.eye(3)
        self._bd = np.zeros(3)
        self.z = np.zeros((3, size))  # rows: value, first, second derivative
        self._started = False

    def reset(self) -> None:
        self._started = False

    def _discretise(self, dt: float) -> None:
        augmented = np.zeros((4, 4))
        augmented[:3, :3] = self._a * dt
        augmented[:3, 3] = self._b * dt
        exact = _expm(augmented)
        self._ad, self._bd, self._dt = exact[:3, :3].copy(), exact[:3, 3].copy(), dt

    def update(self, v: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not self._started:
            self.z[:] = 0.0
            self.z[0] = v
            self._started = True
        elif dt > 0:
            if dt != self._dt:
                self._discretise(dt)
            step_exact(self._ad, self._bd, self.z, np.asarray(v, dtype=np.float64))
        return self.z[0].copy(), self.z[1].copy(), self.z[2].copy()
