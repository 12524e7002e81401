"""A third-order linear tracking differentiator: filtered signal, first and second derivatives.

ż1 = z2, ż2 = z3, ż3 = ω³(v − z1) − 3ω² z2 − 3ω z3: a triple pole at −ω. The paper asks for a
third-order differentiator for the commanded angles' derivatives without saying which; this
one has no chattering and one tuning knob, the bandwidth ω. It is stepped exactly (zero-order
hold on v): z ← A_d z + B_d v, with A_d = exp(A dt) computed once per step size.
"""

from __future__ import annotations

import numpy as np

from firmware_interface.emulator.compiled import flight_code, shared_maths


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


@shared_maths
def differentiate(z: np.ndarray, a_d: np.ndarray, b_d: np.ndarray, started: bool, v: np.ndarray, dt: float) -> None:
    """z ← A_d z + B_d vᵀ in place (each column of z one channel); the first sample starts z at (v, 0, 0)."""
    if not started:
        z[:, :] = 0.0
        z[0, :] = v
        return
    if dt <= 0:
        return
    for channel in range(z.shape[1]):
        value, first, second = z[0, channel], z[1, channel], z[2, channel]
        for row in range(3):
            z[row, channel] = (a_d[row, 0] * value + a_d[row, 1] * first + a_d[row, 2] * second
                               + b_d[row] * v[channel])


@flight_code
def differentiator_step(z: np.ndarray, a_d: np.ndarray, b_d: np.ndarray, started: bool, v: np.ndarray,
                        dt: float) -> None:
    differentiate(z, a_d, b_d, started, v, dt)


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

    def step_arrays(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """(z, A_d, B_d, started) for the compiled `differentiate` of a step of `dt`, discretised for it; the
        differentiator counts as started from this step on."""
        started = self._started
        if started and dt > 0 and dt != self._dt:
            self._discretise(dt)
        self._started = True
        return self.z, self._ad, self._bd, started

    def update(self, v: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(value, first, second derivative) after the sample `v`."""
        z, a_d, b_d, started = self.step_arrays(dt)
        differentiator_step(z, a_d, b_d, started, np.asarray(v, dtype=np.float64), dt)
        return self.z[0].copy(), self.z[1].copy(), self.z[2].copy()
