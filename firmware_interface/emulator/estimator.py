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
from dataclasses import dataclass

import numpy as np
from pygeomag import GeoMag

from firmware_interface.emulator.compiled import flight_code, shared_maths
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
from firmware_interface.hil_codec import GpsFix, SensorReadings, sensor_row
from firmware_interface.hil_frames import (
    HAS_ACCEL,
    HAS_BARO,
    HAS_GYRO,
    HAS_MAG,
    HIL_SENSOR,
    ROW_ACCEL,
    ROW_BARO,
    ROW_MAG_T,
    ROW_PRESENT,
    ROW_SIZE,
    ROW_T_US,
    hil_sensor_row,
)

E3 = np.array((0.0, 0.0, 1.0))
HISTORY_S = 1.0
GPS_ACCEL_FILTER_S = 1.0


@shared_maths
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


@shared_maths
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


# The filter's state in one array, each part a view of it (`Estimator.__init__`): the compiled step updates it in
# place, and its parts keep their names in Python.
Q, RATES, POS, VEL, ACC, PENDING_POS, PENDING_VEL, APPLIED_POS, APPLIED_VEL, BARO_OFFSET = (
    0, 4, 7, 10, 13, 16, 19, 22, 25, 28)
STATE_SIZE = 29
HISTORY_START = 512  # samples the history ring holds at first (2 s at 250 Hz); it doubles when full
HISTORY_ROW = 12  # pos, vel, applied_pos, applied_vel at one sample


@shared_maths
def sensor_step(x: np.ndarray, f: np.ndarray, w: np.ndarray, m: np.ndarray, field_ned: np.ndarray, use_mag: bool,
                g: float, attitude_gain: float, heading_gain: float, share: float, baro_gain: float, baro_alt_m: float,
                history_t_us: np.ndarray, history: np.ndarray, ring: np.ndarray, t_us: int, dt: float) -> None:
    """One aligned sample in place: attitude (`mahony_step`), rates, position and velocity (`propagate`), the baro
    correction (`baro_alt_m` NaN: none this sample; the first sets the offset), then the sample into the history
    ring (`ring` = first, count) and the samples older than HISTORY_S out of it."""
    q, acc = x[Q:Q + 4], x[ACC:ACC + 3]
    q[:] = mahony_step(q, f, w, m, field_ned, use_mag, acc, g, attitude_gain, heading_gain, dt)
    x[RATES:RATES + 3] = w
    pos, vel = x[POS:POS + 3], x[VEL:VEL + 3]
    applied_pos, applied_vel = x[APPLIED_POS:APPLIED_POS + 3], x[APPLIED_VEL:APPLIED_VEL + 3]
    propagate(pos, vel, x[PENDING_POS:PENDING_POS + 3], x[PENDING_VEL:PENDING_VEL + 3], applied_pos, applied_vel,
                 q, f, g, share, dt)
    if not math.isnan(baro_alt_m):
        if math.isnan(x[BARO_OFFSET]):
            x[BARO_OFFSET] = baro_alt_m + pos[2]
        else:
            dz = (x[BARO_OFFSET] - baro_alt_m) - pos[2]
            pos[2] += baro_gain * dz
            vel[2] += baro_gain / 2 * dz
    capacity = history_t_us.size
    at = (ring[0] + ring[1]) % capacity
    history_t_us[at] = t_us
    history[at, 0:3] = pos
    history[at, 3:6] = vel
    history[at, 6:9] = applied_pos
    history[at, 9:12] = applied_vel
    ring[1] += 1
    while ring[1] > 0 and history_t_us[ring[0]] < t_us - HISTORY_S * 1e6:
        ring[0], ring[1] = (ring[0] + 1) % capacity, ring[1] - 1


@shared_maths
def estimate_values(x: np.ndarray) -> np.ndarray:
    """pos, vel, q, η, rates in a new array (what `Estimate` views)."""
    out = np.empty(16)
    out[0:3] = x[POS:POS + 3]
    out[3:6] = x[VEL:VEL + 3]
    out[6:10] = x[Q:Q + 4]
    out[10:13] = quat_to_euler(x[Q:Q + 4])
    out[13:16] = x[RATES:RATES + 3]
    return out


@flight_code
def estimate_of(x: np.ndarray) -> np.ndarray:
    return estimate_values(x)


# what a sensor sample did (`sensor_sample`): nothing (no IMU, or a time step out of range); the IMU taken before
# alignment; the same with what alignment needs (magnetometer and field), which Python then does; the filter stepped
SKIPPED, UNALIGNED, ALIGN, STEPPED = 0, 1, 2, 3
G, ATTITUDE_GAIN, HEADING_GAIN, SPREAD_S, BARO_GAIN = 0, 1, 2, 3, 4  # `sensor_sample`'s `constants`


@flight_code
def sensor_sample(frame: bytes, payload: np.ndarray, row: np.ndarray, x: np.ndarray, imu: np.ndarray,
                  field_ned: np.ndarray, field_known: bool, aligned: bool, constants: np.ndarray,
                  history_t_us: np.ndarray, history: np.ndarray, ring: np.ndarray,
                  last_t_us: int) -> tuple[int, np.ndarray]:
    """One HIL_SENSOR sample, from its frame (`frame` empty: `row` holds it already), into the filter; returns
    what it did and the estimate after it (`estimate_values`). `last_t_us` −1: the first sample. One call from
    the bytes received to the state the controller flies on: a step's sample went through four Python calls and
    two objects before."""
    if len(frame):
        hil_sensor_row(frame, payload, row)
    t_us = int(row[ROW_T_US])
    dt = (t_us - (t_us if last_t_us < 0 else last_t_us)) * 1e-6
    present = int(row[ROW_PRESENT])
    outcome = SKIPPED
    if present & HAS_ACCEL and present & HAS_GYRO and 0.0 <= dt < 0.5:
        imu[0:6] = row[ROW_ACCEL:ROW_ACCEL + 6]  # the accelerometer, then the gyro
        has_mag = present & HAS_MAG != 0
        if has_mag:
            imu[6:9] = row[ROW_MAG_T:ROW_MAG_T + 3]
        if not aligned:
            outcome = ALIGN if has_mag and field_known else UNALIGNED
        else:
            spread_s = constants[SPREAD_S]
            share = min(dt / spread_s, 1.0) if spread_s > 0 else 1.0
            sensor_step(x, imu[0:3], imu[3:6], imu[6:9], field_ned, has_mag and field_known, constants[G],
                        constants[ATTITUDE_GAIN], constants[HEADING_GAIN], share, constants[BARO_GAIN],
                        row[ROW_BARO + 2] if present & HAS_BARO else math.nan, history_t_us, history, ring, t_us, dt)
            outcome = STEPPED
    return outcome, estimate_values(x)


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
        self.x = np.zeros(STATE_SIZE)  # the filter's state; the names below are views of it
        self.x[Q] = 1.0
        self.x[BARO_OFFSET] = math.nan  # set by the first baro sample
        self.q, self.rates = self.x[Q:Q + 4], self.x[RATES:RATES + 3]
        self.pos, self.vel = self.x[POS:POS + 3], self.x[VEL:VEL + 3]
        self.acc = self.x[ACC:ACC + 3]  # NED, from GPS velocity, low-passed: the attitude reference
        self._pending_pos, self._pending_vel = self.x[PENDING_POS:PENDING_POS + 3], self.x[PENDING_VEL:PENDING_VEL + 3]
        self._applied_pos, self._applied_vel = self.x[APPLIED_POS:APPLIED_POS + 3], self.x[APPLIED_VEL:APPLIED_VEL + 3]
        self._last_gps: tuple[int, np.ndarray] | None = None
        self.field_ned: np.ndarray | None = None
        self.origin: LocalFrame | None = None  # about the first fix, as PX4 sets its local origin
        self.aligned = False
        self.t_us: int | None = None
        self.good_since_us: int | None = None
        self.gps_count = 0
        # the last HISTORY_S of samples, oldest first from `_ring[0]` (`_ring[1]` of them): (t_us) and (pos, vel,
        # corrections applied up to then); a past state seen from now is pos/vel plus the corrections applied
        # since, so the ring itself never needs rewriting
        self._history_t_us = np.zeros(HISTORY_START, np.int64)
        self._history = np.zeros((HISTORY_START, HISTORY_ROW))
        self._ring = np.zeros(2, np.int64)
        self._imu = np.zeros(9)  # this sample's accelerometer, gyro and magnetometer, as the compiled step takes them
        self._row = np.zeros(ROW_SIZE)  # the sample as a step row (`hil_frames.ROW_*`)
        self._payload = np.zeros(HIL_SENSOR[2], np.uint8)  # a HIL_SENSOR frame's payload, trimmed zeros restored
        self._constants = np.zeros(5)  # what `sensor_sample` takes of the settings (G, ATTITUDE_GAIN, ...)
        self._constants_of: EstimatorSettings | None = None  # the settings they are of

    # --- readiness ----------------------------------------------------------------
    def ready(self) -> bool:
        """Settled: aligned, origin set, and `settle_s` of data since then (the arming check)."""
        if not (self.aligned and self.origin is not None and self.t_us is not None and self.good_since_us):
            return False
        return (self.t_us - self.good_since_us) * 1e-6 >= self.settings.settle_s

    def estimate(self) -> Estimate:
        e = estimate_of(self.x)
        return Estimate(e[0:3], e[3:6], e[6:10], e[10:13], e[13:16])

    # --- sensors ------------------------------------------------------------------
    def on_sensors(self, r: SensorReadings) -> np.ndarray:
        """A sample given as readings (`on_sensor_frame` with the row already made)."""
        self._row[:] = sensor_row(r)
        return self.on_sensor_frame(b"")

    def on_sensor_frame(self, frame: bytes) -> np.ndarray:
        """A HIL_SENSOR frame's sample; returns the estimate after it (`estimate_values`'s array)."""
        if self._ring[1] == self._history_t_us.size:
            self._grow_history()
        if self._constants_of is not self.settings:
            s = self._constants_of = self.settings
            self._constants[:] = (self.g, s.attitude_gain, s.heading_gain, s.correction_spread_s, s.baro_gain)
        field = self.field_ned
        outcome, estimate = sensor_sample(frame, self._payload, self._row, self.x, self._imu,
                                          E3 if field is None else field, field is not None, self.aligned,
                                          self._constants, self._history_t_us, self._history, self._ring,
                                          -1 if self.t_us is None else self.t_us)
        self.t_us = int(self._row[ROW_T_US])
        if outcome == ALIGN:
            self._align(self._imu[0:3], self._imu[6:9])
            return estimate_of(self.x)
        return estimate

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
    def _grow_history(self) -> None:
        """Twice the room, the samples kept in order from the start."""
        order = self._history_order()
        size = 2 * self._history_t_us.size
        times, rows = np.zeros(size, np.int64), np.zeros((size, HISTORY_ROW))
        times[:order.size], rows[:order.size] = self._history_t_us[order], self._history[order]
        self._history_t_us, self._history = times, rows
        self._ring[:] = (0, order.size)

    def _history_order(self) -> np.ndarray:
        """The ring's slots, oldest first."""
        return (self._ring[0] + np.arange(self._ring[1])) % self._history_t_us.size

    def _state_at(self, t_us: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The sample nearest `t_us` (the oldest of equally near ones), seen from now."""
        order = self._history_order()
        if not order.size:
            return None
        row = self._history[order[np.argmin(np.abs(self._history_t_us[order] - t_us))]]
        pos, vel, applied_pos, applied_vel = row[0:3], row[3:6], row[6:9], row[9:12]
        return pos + (self._applied_pos - applied_pos), vel + (self._applied_vel - applied_vel)

    def _align(self, f: np.ndarray, m: np.ndarray) -> None:
        roll = math.atan2(-f[1], -f[2])
        pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
        level = quat_to_dcm(euler_to_quat(roll, pitch, 0.0))
        m_level = level @ m  # field with the tilt removed, still in the heading frame
        field = self.field_ned
        yaw = wrap_pi(math.atan2(field[1], field[0]) - math.atan2(m_level[1], m_level[0]))  # type: ignore[index]
        self.q[:] = euler_to_quat(roll, pitch, yaw)
        self.aligned = True
        self.good_since_us = self.t_us
