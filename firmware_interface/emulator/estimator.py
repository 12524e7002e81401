"""The emulator's state estimator: what PX4's EKF2 does for a flight, in a small fixed-gain form.

Attitude: a Mahony complementary filter. The accelerometer reference is not gravity but the
expected specific force Rᵀ(â − g e3), with â the low-passed rate of change of the GPS velocity:
a multirotor's accelerometer reads thrust and drag, and equals −g rotated only when the vehicle
is not accelerating. (â must not come from the accelerometer itself: the reference would then
equal the measurement and tilt would go unobserved.) Heading from the magnetometer against the WMM
field at the first GPS fix.
Position/velocity: driven by the rotated accelerometer, corrected by baro height and by GPS
against the state buffered at the fix's measurement time (fix arrival minus the configured GPS
delay, as EKF2_GPS_DELAY), the correction then applied to the present state.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from pygeomag import GeoMag

from firmware_interface.emulator.compiled import flight_code
from firmware_interface.emulator.config import EstimatorSettings
from firmware_interface.emulator.geometry import (
    dot,
    euler_to_quat,
    mat_t_vec,
    mat_vec,
    quat_multiply,
    quat_to_dcm,
    quat_to_euler,
    wrap_pi,
)
from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2, LocalFrame
from firmware_interface.hil_codec import GpsFix, SensorReadings

E3 = np.array((0.0, 0.0, 1.0))
HISTORY_S = 1.0
GPS_ACCEL_FILTER_S = 1.0


@flight_code
def mahony_step(q: np.ndarray, f: np.ndarray, w: np.ndarray, m: np.ndarray, field_ned: np.ndarray, use_mag: bool,
                acc_ned: np.ndarray, g: float, attitude_gain: float, heading_gain: float, dt: float) -> np.ndarray:
    """The attitude quaternion after `dt`: gyro rates plus the accelerometer's and magnetometer's corrections."""
    rot = quat_to_dcm(q)
    correction = np.zeros(3)
    expected = mat_t_vec(rot, acc_ned - g * E3)  # the specific force the accelerometer should read
    nf, ne = math.sqrt(dot(f, f)), math.sqrt(dot(expected, expected))
    if nf > 1.0 and ne > 1.0:
        a, b = f / nf, expected / ne
        correction += attitude_gain * np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                                a[0] * b[1] - a[1] * b[0]))
    if use_mag:
        m_ned = mat_vec(rot, m)
        err = wrap_pi(math.atan2(m_ned[1], m_ned[0]) - math.atan2(field_ned[1], field_ned[0]))
        correction += -heading_gain * err * mat_t_vec(rot, E3)
    omega = w + correction
    rate = math.sqrt(dot(omega, omega))
    if rate <= 0:
        return q.copy()
    half = 0.5 * rate * dt
    axis_share = math.sin(half) / rate
    dq = np.array((math.cos(half), axis_share * omega[0], axis_share * omega[1], axis_share * omega[2]))
    q_next = quat_multiply(q, dq)
    return q_next / math.sqrt(q_next[0] ** 2 + q_next[1] ** 2 + q_next[2] ** 2 + q_next[3] ** 2)


@flight_code
def propagate(pos: np.ndarray, vel: np.ndarray, pending_pos: np.ndarray, pending_vel: np.ndarray,
              applied_pos: np.ndarray, applied_vel: np.ndarray, q: np.ndarray, f: np.ndarray, g: float, share: float,
              dt: float) -> None:
    """Position and velocity (NED) after `dt` in place: `share` of the pending GPS correction, then the rotated
    accelerometer."""
    step_pos, step_vel = share * pending_pos, share * pending_vel
    pending_pos -= step_pos
    pending_vel -= step_vel
    pos += step_pos
    vel += step_vel
    applied_pos += step_pos
    applied_vel += step_vel
    acc = mat_vec(quat_to_dcm(q), f) + g * E3
    pos += vel * dt + 0.5 * acc * dt * dt
    vel += acc * dt


@dataclass(frozen=True)
class Estimate:
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    q_wxyz: np.ndarray
    eta: np.ndarray
    rates_frd: np.ndarray


class Estimator:
    def __init__(self, settings: EstimatorSettings, g: float = STANDARD_GRAVITY_M_S2) -> None:
        self.settings = settings
        self.g = g
        self.q = np.array((1.0, 0.0, 0.0, 0.0))
        self.pos = np.zeros(3)
        self.vel = np.zeros(3)
        self.acc = np.zeros(3)  # NED, from GPS velocity, low-passed: the attitude reference
        self._last_gps: tuple[int, np.ndarray] | None = None
        self.rates = np.zeros(3)
        self.field_ned: np.ndarray | None = None
        self.origin: LocalFrame | None = None  # about the first fix, as PX4 sets its local origin
        self.baro_offset: float | None = None
        self.aligned = False
        self.t_us: int | None = None
        self.good_since_us: int | None = None
        self.gps_count = 0
        # (t_us, pos, vel, corrections applied up to then): a past state seen from now is
        # pos/vel plus the corrections applied since, so the buffer itself never needs rewriting
        self._history: deque[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = deque()
        self._pending_pos = np.zeros(3)
        self._pending_vel = np.zeros(3)
        self._applied_pos = np.zeros(3)
        self._applied_vel = np.zeros(3)

    # --- readiness ----------------------------------------------------------------
    def ready(self) -> bool:
        """Settled: aligned, origin set, and `settle_s` of data since then (the arming check)."""
        if not (self.aligned and self.origin is not None and self.t_us is not None and self.good_since_us):
            return False
        return (self.t_us - self.good_since_us) * 1e-6 >= self.settings.settle_s

    def estimate(self) -> Estimate:
        return Estimate(self.pos.copy(), self.vel.copy(), self.q.copy(), quat_to_euler(self.q), self.rates.copy())

    # --- sensors ------------------------------------------------------------------
    def on_sensors(self, r: SensorReadings) -> None:
        if self.t_us is None:
            self.t_us = r.t_us
        dt = (r.t_us - self.t_us) * 1e-6
        self.t_us = r.t_us
        if r.accel_frd is None or r.gyro_frd is None or not 0.0 <= dt < 0.5:
            return
        f = np.array(r.accel_frd)
        w = np.array(r.gyro_frd)
        if not self.aligned:
            if r.mag_frd_t is not None and self.field_ned is not None:
                self._align(f, np.array(r.mag_frd_t))
            return
        self._attitude(f, w, None if r.mag_frd_t is None else np.array(r.mag_frd_t), dt)
        self._propagate(f, dt)
        if r.baro is not None:
            self._baro(r.baro.pressure_alt_m)
        self._history.append((r.t_us, self.pos.copy(), self.vel.copy(), self._applied_pos.copy(),
                              self._applied_vel.copy()))
        while self._history and self._history[0][0] < r.t_us - HISTORY_S * 1e6:
            self._history.popleft()

    def on_gps(self, fix: GpsFix, now_us: int) -> None:
        if fix.fix_type < 3:
            return
        if self.origin is None:
            self.origin = LocalFrame(fix.lat_deg, fix.lon_deg, fix.alt_msl_m)
            result = GeoMag().calculate(glat=fix.lat_deg, glon=fix.lon_deg, alt=fix.alt_msl_m / 1000,
                                        time=self.settings.mag_epoch_year, allow_date_outside_lifespan=True)
            self.field_ned = np.array((result.x, result.y, result.z)) * 1e-9
            return
        if not self.aligned:
            return
        self.gps_count += 1
        z_pos = np.array(self.origin.to_ned(fix.lat_deg, fix.lon_deg, fix.alt_msl_m))
        z_vel = np.array(fix.vel_ned)
        if self._last_gps is not None and fix.t_us > self._last_gps[0]:
            gap = (fix.t_us - self._last_gps[0]) * 1e-6
            self.acc += min(gap / GPS_ACCEL_FILTER_S, 1.0) * ((z_vel - self._last_gps[1]) / gap - self.acc)
        self._last_gps = (fix.t_us, z_vel)
        measured_us = now_us - int(self.settings.gps_delay_s * 1e6)
        then = self._state_at(measured_us)
        if then is None:
            return
        p_then, v_then = then
        dp, dv = z_pos - p_then, z_vel - v_then
        # fixed gains per fix (5–10 Hz): a steady-state Kalman filter in spirit, tuned for metre-level GNSS
        s = self.settings
        k_pos = np.array((s.gps_pos_gain_xy, s.gps_pos_gain_xy, s.gps_pos_gain_z))
        k_vel_from_pos = np.array((s.gps_vel_from_pos_gain, s.gps_vel_from_pos_gain, s.gps_vel_from_pos_gain / 8))
        k_vel = s.gps_vel_gain
        # Spread the correction over `correction_spread_s` instead of stepping the state: a 5 Hz
        # step in velocity would reach the attitude commands through the position loop's damping.
        self._pending_pos += k_pos * dp
        self._pending_vel += k_vel_from_pos * dp + k_vel * dv

    # --- internals ----------------------------------------------------------------
    def _state_at(self, t_us: int) -> tuple[np.ndarray, np.ndarray] | None:
        if not self._history:
            return None
        _, pos, vel, applied_pos, applied_vel = min(self._history, key=lambda h: abs(h[0] - t_us))
        return pos + (self._applied_pos - applied_pos), vel + (self._applied_vel - applied_vel)

    def _align(self, f: np.ndarray, m: np.ndarray) -> None:
        roll = math.atan2(-f[1], -f[2])
        pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
        level = quat_to_dcm(euler_to_quat(roll, pitch, 0.0))
        m_level = level @ m  # field with the tilt removed, still in the heading frame
        field = self.field_ned
        yaw = wrap_pi(math.atan2(field[1], field[0]) - math.atan2(m_level[1], m_level[0]))  # type: ignore[index]
        self.q = euler_to_quat(roll, pitch, yaw)
        self.aligned = True
        self.good_since_us = self.t_us

    def _attitude(self, f: np.ndarray, w: np.ndarray, m: np.ndarray | None, dt: float) -> None:
        s = self.settings
        field = self.field_ned
        if m is None or field is None:
            m, field, use_mag = E3, E3, False  # placeholders the compiled step does not read
        else:
            use_mag = True
        self.q = mahony_step(self.q, f, w, m, field, use_mag, self.acc, self.g, s.attitude_gain, s.heading_gain, dt)
        self.rates = w

    def _propagate(self, f: np.ndarray, dt: float) -> None:
        spread_s = self.settings.correction_spread_s
        share = min(dt / spread_s, 1.0) if spread_s > 0 else 1.0
        propagate(self.pos, self.vel, self._pending_pos, self._pending_vel, self._applied_pos, self._applied_vel,
                  self.q, f, self.g, share, dt)

    def _baro(self, pressure_alt_m: float) -> None:
        if self.baro_offset is None:
            self.baro_offset = pressure_alt_m + self.pos[2]
            return
        z_baro = self.baro_offset - pressure_alt_m
        dz = z_baro - self.pos[2]
        self.pos[2] += self.settings.baro_gain * dz
        self.vel[2] += self.settings.baro_gain / 2 * dz
