"""Foxglove's well-known messages built from the bench's channel samples, so that Foxglove's 3D, Map and
Plot panels work on a recording or a live run with no set-up.

Frames: `ned` is the bench's local NED frame (origin at home); `enu` is its z-up twin that a 3D view
uses as display frame; `vehicle` is the true body FRD frame, `board_estimate` the board's own estimate
of it (in the board's local frame, which for PX4 may sit up to ~1 m from the bench's). The types come
from foxglove-sdk (protobuf), so the schemas are Foxglove's own.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from foxglove import messages as fm

from firmware_interface.emulator.geometry import euler_to_quat
from firmware_interface.geodesy import LocalFrame
from hil.scenario.mission import MissionPlan
from hil.scenario.reference import PatrolRef
from hil.scenario.schema import Scenario

# NED axes seen from ENU: a half turn about (1, 1, 0)/√2 maps x→y, y→x, z→−z
ENU_FROM_NED_WXYZ = (0.0, math.sqrt(0.5), math.sqrt(0.5), 0.0)
FOXGLOVE_TOPICS: dict[str, Any] = {  # topic -> foxglove.messages class
   "foxglove/tf": fm.FrameTransforms, "foxglove/reference": fm.PoseInFrame,
                   "foxglove/gps": fm.LocationFix, "foxglove/truth_fix": fm.LocationFix,
                   "foxglove/scene": fm.SceneUpdate}
# the state-driven topics are decimated to this rate (the full-rate truth is in hil/state)
VIEW_RATE_HZ = 50.0
SCENE_STEP_S = 0.1  # spacing of the drawn reference path
_DIAGONAL_KNOWN = fm.LocationFixPositionCovarianceType.DiagonalKnown


def timestamp(t_ns: int) -> fm.Timestamp:
    return fm.Timestamp(sec=t_ns // 1_000_000_000, nsec=t_ns % 1_000_000_000)


def _quat(q_wxyz: Iterable[float]) -> fm.Quaternion:
    w, x, y, z = q_wxyz
    return fm.Quaternion(x=x, y=y, z=z, w=w)


def _vec(v: Iterable[float]) -> fm.Vector3:
    x, y, z = v
    return fm.Vector3(x=x, y=y, z=z)


def _transform(stamp: fm.Timestamp, parent: str, child: str, translation: Iterable[float],
               rotation: fm.Quaternion) -> fm.FrameTransform:
    return fm.FrameTransform(timestamp=stamp, parent_frame_id=parent, child_frame_id=child,
                             translation=_vec(translation), rotation=rotation)


class FoxgloveViews:
    """Turns channel samples into Foxglove messages; `messages()` returns (topic, message) pairs."""

    def __init__(self, frame: LocalFrame, start_ns: int) -> None:
        self.frame = frame
        self.start_ns = start_ns
        self._period_us = int(1e6 / VIEW_RATE_HZ)
        self._next_us = 0
        self._view_t_us = -1  # the last step whose state went out: its reference goes out too
        self._board_rpy: list[float] | None = None

    def messages(self, samples: Iterable[tuple[str, dict[str, Any]]]) -> list[tuple[str, Any]]:
        out: list[tuple[str, Any]] = []
        for channel, sample in samples:
            if channel == "board/attitude":
                self._board_rpy = sample["rpy"]
            elif channel == "board/local_position_ned" and self._board_rpy is not None:
                stamp = timestamp(self.start_ns + sample["t_us"] * 1000)
                out.append(("foxglove/tf", fm.FrameTransforms(transforms=[_transform(
                    stamp, "ned", "board_estimate", sample["pos_ned"], _quat(euler_to_quat(*self._board_rpy)))])))
            elif channel == "sensors/gps":
                out.append(("foxglove/gps", self._gps_fix(sample)))
            elif channel == "state" and sample["t_us"] >= self._next_us:
                self._next_us = max(self._next_us + self._period_us, sample["t_us"])
                self._view_t_us = sample["t_us"]
                out.extend(self._state_views(sample))
            elif channel == "reference" and sample["t_us"] == self._view_t_us:
                out.append(("foxglove/reference", self._reference_pose(sample)))
        return out

    def _state_views(self, state: dict[str, Any]) -> list[tuple[str, Any]]:
        stamp = timestamp(self.start_ns + state["t_us"] * 1000)
        transforms = fm.FrameTransforms(transforms=[
            _transform(stamp, "enu", "ned", (0.0, 0.0, 0.0), _quat(ENU_FROM_NED_WXYZ)),
            _transform(stamp, "ned", "vehicle", state["pos_ned"], _quat(state["q_wxyz"]))])
        lat, lon, alt = self.frame.to_geodetic(*state["pos_ned"])
        fix = fm.LocationFix(timestamp=stamp, frame_id="vehicle", latitude=lat, longitude=lon, altitude=alt,
                             heading=state["rpy"][2], color=fm.Color(r=0.1, g=0.4, b=1.0, a=1.0))
        return [("foxglove/tf", transforms), ("foxglove/truth_fix", fix)]

    def _reference_pose(self, ref: dict[str, Any]) -> fm.PoseInFrame:
        stamp = timestamp(self.start_ns + ref["t_us"] * 1000)
        pose = fm.Pose(position=fm.Vector3(x=ref["pos_ned"][0], y=ref["pos_ned"][1], z=ref["pos_ned"][2]),
                       orientation=_quat(euler_to_quat(0.0, 0.0, ref["yaw"])))
        return fm.PoseInFrame(timestamp=stamp, frame_id="ned", pose=pose)

    def _gps_fix(self, gps: dict[str, Any]) -> fm.LocationFix:
        n, e, d = gps["vel_ned"]
        h, v = gps["eph_m"] ** 2, gps["epv_m"] ** 2
        return fm.LocationFix(timestamp=timestamp(self.start_ns + gps["t_us"] * 1000), frame_id="gps",
                              latitude=gps["lat_deg"], longitude=gps["lon_deg"], altitude=gps["alt_msl_m"],
                              position_covariance=[h, 0, 0, 0, h, 0, 0, 0, v],
                              position_covariance_type=_DIAGONAL_KNOWN, velocity=fm.Vector3(x=e, y=n, z=-d),
                              color=fm.Color(r=1.0, g=0.5, b=0.0, a=1.0))


def mission_scene(scenario: Scenario, t_ns: int) -> fm.SceneUpdate:
    """The mission's reference path, take-off included (and the inspected power line, where the scenario
    has one), drawn once at the start in the `ned` frame."""
    plan = MissionPlan.build(scenario)
    times = np.arange(-plan.takeoff_s, plan.duration_s + 1e-9, SCENE_STEP_S)
    path_ned = [tuple(float(v) for v in plan.sample(float(t)).pos_ned) for t in times]
    ref = scenario.reference
    power_line = (ref.line_start_ned, ref.line_end_ned) if isinstance(ref, PatrolRef) else None
    return _scene(path_ned, power_line, t_ns)


def _scene(path_ned: list[tuple[float, ...]], power_line_ned: tuple[Any, Any] | None, t_ns: int) -> fm.SceneUpdate:
    stamp = timestamp(t_ns)

    def line(points: Iterable[Iterable[float]], rgba: tuple[float, float, float, float],
             width: float) -> fm.LinePrimitive:
        r, g, b, a = rgba
        return fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineStrip, thickness=width, scale_invariant=False,
                                points=[fm.Point3(x=x, y=y, z=z) for x, y, z in points],
                                color=fm.Color(r=r, g=g, b=b, a=a))

    entities = [fm.SceneEntity(timestamp=stamp, frame_id="ned", id="reference_path",
                               lines=[line(path_ned, (0.2, 0.5, 1.0, 0.9), 0.05)])]
    if power_line_ned is not None:
        entities.append(fm.SceneEntity(timestamp=stamp, frame_id="ned", id="power_line",
                                       lines=[line(power_line_ned, (0.9, 0.1, 0.1, 1.0), 0.08)]))
    return fm.SceneUpdate(entities=entities)
