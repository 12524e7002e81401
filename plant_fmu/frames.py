"""Frames a plant may use, and the rotations that bring its values into the bench's NED earth and FRD
body frames. Each conversion is its own inverse, so the same matrix turns the bench's inputs into the
FMU's frames."""

from __future__ import annotations

from typing import Literal

import numpy as np

EarthFrame = Literal["NED", "ENU"]
BodyFrame = Literal["FRD", "FLU"]

# v_ned = M v_fmu; None: the FMU's frame is the bench's
EARTH_TO_NED: dict[str, np.ndarray | None] = {
    "NED": None,
    "ENU": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
}
BODY_TO_FRD: dict[str, np.ndarray | None] = {"FRD": None, "FLU": np.diag([1.0, -1.0, -1.0])}


def quat_to_dcm(q_wxyz: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion (scalar first), Hamilton convention."""
    w, x, y, z = q_wxyz
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def dcm_to_quat(r: np.ndarray) -> np.ndarray:
    """The unit quaternion (scalar first, w >= 0) of a rotation matrix, from its largest diagonal term."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = np.array([0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s])
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k])
        q = np.empty(4)
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    return q if q[0] >= 0 else -q


def euler_zyx_to_dcm(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll): body to earth."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def dcm_to_euler_zyx(r: np.ndarray) -> np.ndarray:
    """(roll, pitch, yaw) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return np.array([np.arctan2(r[2, 1], r[2, 2]), np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)),
                     np.arctan2(r[1, 0], r[0, 0])])


def to_bench_attitude(r_fmu: np.ndarray, earth: EarthFrame, body: BodyFrame) -> np.ndarray:
    """The FMU's body-to-earth rotation in its own frames, as FRD to NED."""
    e, b = EARTH_TO_NED[earth], BODY_TO_FRD[body]
    r = r_fmu if e is None else e @ r_fmu
    return r if b is None else r @ b
