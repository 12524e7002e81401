"""GPS receiver: rate, Gauss-Markov plus white position error, velocity noise, a delay line."""

from __future__ import annotations

import math

import numpy as np

from firmware_interface.geodesy import geodetic_of
from firmware_interface.hil_codec import GpsFix, readings_of_row
from firmware_interface.hil_frames import (
    HAS_GPS,
    ROW_EPH_M,
    ROW_EPV_M,
    ROW_FIX_TYPE,
    ROW_GPS_T_US,
    ROW_GPS_VEL_NED,
    ROW_LAT_DEG,
    ROW_PRESENT,
    ROW_SATELLITES,
    ROW_SIZE,
)
from hil.sensors.config import GpsConfig
from hil.sensors.geodesy import Home
from hil.sensors.noise import SENSORS, NormalStream

# positions in a receiver's parameter array (MARKOV changes, the slow error's state) and in its integer state
WHITE, DRIVE, MARKOV, PHI, VEL_NOISE, EPH, EPV, FIX_TYPE, SATELLITES = 0, 3, 6, 9, 10, 11, 12, 13, 14
NEXT_US, PERIOD_US, DELAY_US, HEAD, COUNT = 0, 1, 2, 3, 4  # NEXT_US -1: no measurement yet
# a measured fix waiting in the delay line: when it is delivered, when it was measured, lat, lon, alt, NED velocity
DELIVER_US, FIX_T_US, FIX = 0, 1, 2


@SENSORS.inline
def gps_measure(gps: np.ndarray, noise: np.ndarray, cursor: np.ndarray, frame: np.ndarray, pos_ned: np.ndarray,
                vel_ned: np.ndarray, out: np.ndarray) -> None:
    """lat, lon, alt and the NED velocity of a fix measured now into out[0:6]; the slow error steps."""
    n = noise[cursor[0]]
    cursor[0] += 1
    pos = np.empty(3)
    for k in range(3):
        gps[MARKOV + k] = gps[PHI] * gps[MARKOV + k] + gps[DRIVE + k] * n[k]
        pos[k] = pos_ned[k] + gps[MARKOV + k] + gps[WHITE + k] * n[3 + k]
        out[3 + k] = vel_ned[k] + gps[VEL_NOISE] * n[6 + k]
    out[0], out[1], out[2] = geodetic_of(pos[0], pos[1], pos[2], frame)


@SENSORS.inline
def gps_step(gps: np.ndarray, state: np.ndarray, line: np.ndarray, noise: np.ndarray, cursor: np.ndarray,
             frame: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray, row: np.ndarray) -> None:
    """Every bench step: measure when due (into the delay line), and put the latest fix due by now, if any, into
    the step's row (`hil_frames.ROW_GPS_*`)."""
    if state[NEXT_US] < 0:
        state[NEXT_US] = t_us
    if t_us >= state[NEXT_US]:
        slot = line[(state[HEAD] + state[COUNT]) % line.shape[0]]
        slot[DELIVER_US], slot[FIX_T_US] = t_us + state[DELAY_US], t_us
        gps_measure(gps, noise, cursor, frame, pos_ned, vel_ned, slot[FIX:])
        state[COUNT] += 1
        state[NEXT_US] += state[PERIOD_US]
    delivered = -1
    while state[COUNT] > 0 and line[state[HEAD], DELIVER_US] <= t_us:
        delivered = state[HEAD]
        state[HEAD] = (state[HEAD] + 1) % line.shape[0]
        state[COUNT] -= 1
    if delivered >= 0:
        fix = line[delivered]
        row[ROW_GPS_T_US] = fix[FIX_T_US]
        row[ROW_LAT_DEG:ROW_GPS_VEL_NED + 3] = fix[FIX:FIX + 6]
        row[ROW_EPH_M], row[ROW_EPV_M] = gps[EPH], gps[EPV]
        row[ROW_FIX_TYPE], row[ROW_SATELLITES] = gps[FIX_TYPE], gps[SATELLITES]
        row[ROW_PRESENT] = int(row[ROW_PRESENT]) | HAS_GPS


@SENSORS.compiled
def _step(gps: np.ndarray, state: np.ndarray, line: np.ndarray, noise: np.ndarray, cursor: np.ndarray,
          frame: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray, row: np.ndarray) -> None:
    gps_step(gps, state, line, noise, cursor, frame, t_us, pos_ned, vel_ned, row)


class Gps:
    """Measures every 1/rate s; each fix is delivered `delay_s` after it was measured."""

    def __init__(self, config: GpsConfig, home: Home, rng: np.random.Generator) -> None:
        c = config
        period_us, delay_us = round(1e6 / c.rate_hz), round(c.delay_s * 1e6)
        sigma = np.array((c.pos_markov_sigma_xy, c.pos_markov_sigma_xy, c.pos_markov_sigma_z))
        phi = math.exp(-1.0 / (c.rate_hz * c.pos_markov_tau_s))
        drive = sigma * math.sqrt(1.0 - phi * phi)  # keeps the steady-state σ at `sigma`
        markov = sigma * rng.standard_normal(3)  # start in steady state
        self.params = np.array((c.pos_white_noise_xy, c.pos_white_noise_xy, c.pos_white_noise_z, *drive, *markov, phi,
                                c.vel_noise, c.eph_m, c.epv_m, c.fix_type, c.satellites))
        self.state = np.array((-1, period_us, delay_us, 0, 0), dtype=np.int64)
        self.line = np.zeros((delay_us // period_us + 2, FIX + 6))  # every fix measured and not yet delivered
        self.frame = np.array(home.frame.constants)
        self.noise = NormalStream(rng, 9)

    @property
    def markov(self) -> np.ndarray:
        return self.params[MARKOV:MARKOV + 3]

    def step(self, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray) -> GpsFix | None:
        """Call every bench step; returns the fix delivered at this step, if any."""
        self.noise.refill()
        row = np.zeros(ROW_SIZE)
        _step(self.params, self.state, self.line, self.noise.rows, self.noise.cursor, self.frame, int(t_us),
              np.asarray(pos_ned, dtype=np.float64), np.asarray(vel_ned, dtype=np.float64), row)
        return readings_of_row(row)[1]
