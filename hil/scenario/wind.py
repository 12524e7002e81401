"""Wind in NED: a steady vector, 1-cosine gusts, and Dryden turbulence (MIL-F-8785C, seeded)."""

from __future__ import annotations

import math

import numpy as np

FT = 0.3048
KNOT = 0.514444
TURBULENCE_W20_KT = {"light": 15.0, "moderate": 30.0, "severe": 45.0}  # wind at 20 ft, MIL-F-8785C
BLOCK = 256  # steps of turbulence filtered at once: ~0.4 ms, which a paced step absorbs (as the sensors' noise)


def one_minus_cosine(t: float, start_s: float, duration_s: float) -> float:
    """0 → 1 → 0 shape of a discrete gust: ½(1 − cos(2π (t − start)/duration)) inside the gust."""
    if t < start_s or t > start_s + duration_s:
        return 0.0
    return 0.5 * (1.0 - math.cos(2 * math.pi * (t - start_s) / duration_s))


class DrydenTurbulence:
    """Low-altitude Dryden model (MIL-F-8785C / MIL-HDBK-1797), h in ft for the scale formulas.

    σ_w = 0.1·W20, σ_u/σ_w = σ_v/σ_w = 1/(0.177 + 0.000823 h)^0.4,
    L_w = h, L_u = L_v = h/(0.177 + 0.000823 h)^1.2;
    H_u = σ_u √(2L_u/πV) / (1 + (L_u/V) s),
    H_v = σ_v √(L_v/πV) (1 + √3 (L_v/V) s) / (1 + (L_v/V) s)², H_w likewise with L_w.
    u is along the mean wind, v across it, w vertical (down in NED). The spectra are normalised so that
    ∫₀^∞ |H(jω)|² dω = σ², which takes white noise of two-sided PSD π: sampled as N(0, 1)·√(π/dt), held
    over the step, through filters discretised exactly.

    The generator is the turbulence's own, so its draws are taken BLOCK steps at a time and filtered ahead: the
    same numbers in the same order as a step at a time, bit for bit, and off the bench's step (a step's sample
    is then a row read).
    """

    def __init__(self, w20_m_s: float, altitude_m: float, airspeed_m_s: float, heading_rad: float,
                 dt: float, rng: np.random.Generator) -> None:
        h_ft = max(altitude_m / FT, 10.0)  # the low-altitude model is defined from 10 ft up
        ratio = 1.0 / (0.177 + 0.000823 * h_ft) ** 0.4
        self.sigma_w = 0.1 * w20_m_s
        self.sigma_u = self.sigma_v = self.sigma_w * ratio
        self.length_w = h_ft * FT
        self.length_u = self.length_v = h_ft / (0.177 + 0.000823 * h_ft) ** 1.2 * FT
        self.airspeed = max(airspeed_m_s, 1.0)
        self._cos, self._sin = math.cos(heading_rad), math.sin(heading_rad)
        self.dt = dt
        self.rng = rng
        self._ahead: list[tuple[float, float, float]] = []  # the next steps' velocities, filtered ahead
        self._next = 0  # the row of `_ahead` the next step takes
        self._u = self._first_order(self.sigma_u, self.length_u)
        self._v = self._second_order(self.sigma_v, self.length_v)
        self._w = self._second_order(self.sigma_w, self.length_w)

    def _first_order(self, sigma: float, length: float) -> list[float]:
        """[a, b, x] of x ← a·x + b·n for H = K/(1 + τs), held input."""
        tau = length / self.airspeed
        gain = sigma * math.sqrt(2 * length / (math.pi * self.airspeed))
        a = math.exp(-self.dt / tau)
        return [a, gain * (1 - a), 0.0]

    def _second_order(self, sigma: float, length: float) -> list[float]:
        """[a11, a12, a21, a22, b1, b2, c1, c2, x1, x2] for H = K(1 + √3 τs)/(1 + τs)², held input."""
        tau = length / self.airspeed
        gain = sigma * math.sqrt(length / (math.pi * self.airspeed))
        a_c = np.array(((0.0, 1.0), (-1.0 / tau**2, -2.0 / tau)))
        b_c = np.array((0.0, 1.0 / tau**2))
        pole = -1.0 / tau  # a double pole: exp(A dt) = e^{λ dt} (I + dt (A − λ I))
        a_d = math.exp(pole * self.dt) * (np.eye(2) + self.dt * (a_c - pole * np.eye(2)))
        b_d = np.linalg.solve(a_c, (a_d - np.eye(2)) @ b_c)
        return [*a_d.ravel().tolist(), *b_d.tolist(), gain, gain * math.sqrt(3) * tau, 0.0, 0.0]

    @staticmethod
    def _step2(f: list[float], n: float) -> float:
        x1, x2 = f[8], f[9]
        f[8], f[9] = f[0] * x1 + f[1] * x2 + f[4] * n, f[2] * x1 + f[3] * x2 + f[5] * n
        return f[6] * f[8] + f[7] * f[9]

    def sample(self) -> tuple[float, float, float]:
        """Turbulence velocity in NED for this step, m/s."""
        if self._next == len(self._ahead):
            self._ahead = self._filter(self.rng.standard_normal((BLOCK, 3)) * math.sqrt(math.pi / self.dt))
            self._next = 0
        self._next += 1
        return self._ahead[self._next - 1]

    def _filter(self, noise: np.ndarray) -> list[tuple[float, float, float]]:
        """The velocities of the steps driven by `noise` (a row a step), the filters' states carried on."""
        u, c, s = self._u, self._cos, self._sin
        velocities = []
        for n_u, n_v, n_w in noise.tolist():
            u[2] = u[0] * u[2] + u[1] * n_u
            along, across, down = u[2], self._step2(self._v, n_v), self._step2(self._w, n_w)
            velocities.append((along * c - across * s, along * s + across * c, down))
        return velocities
