"""Foxglove's well-known messages built from the bench's channel samples, so that Foxglove's 3D, Map and
Plot panels work on a recording or a live run with no set-up.

Frames: `ned` is the bench's local NED frame (origin at home); `enu` is its z-up twin that a 3D view
uses as display frame; `vehicle` is the true body FRD frame, `board_estimate` the board's own estimate
of it (in the board's local frame, which for PX4 may sit up to ~1 m from the bench's). The types come
from foxglove-sdk (protobuf), so the schemas are Foxglove's own.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
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


# the parts every view shares (a message's field takes a copy of them)
_ORIGIN = _vec((0.0, 0.0, 0.0))
_ENU_FROM_NED = _quat(ENU_FROM_NED_WXYZ)
_TRUTH_COLOUR = fm.Color(r=0.1, g=0.4, b=1.0, a=1.0)
_GPS_COLOUR = fm.Color(r=1.0, g=0.5, b=0.0, a=1.0)


class FoxgloveViews:
    """Turns channel samples into Foxglove messages; `messages()` returns (topic, message) pairs. A step brings
    ~8 samples and ~0.8 views, so each sample is routed by one lookup of its channel (the recorder calls this
    every step)."""

    def __init__(self, frame: LocalFrame, start_ns: int) -> None:
        self.frame = frame
        self.start_ns = start_ns
        self._period_us = int(1e6 / VIEW_RATE_HZ)
        self._next_us = 0
        self._view_t_us = -1  # the last step whose state went out: its reference goes out too
        self._board_rpy: list[float] | None = None
        self._routes: dict[str, Callable[[dict[str, Any], list[tuple[str, Any]]], None]] = {
            "board/attitude": self._board_attitude, "board/local_position_ned": self._board_position,
            "sensors/gps": self._gps_fix, "state": self._state_views, "reference": self._reference_pose}

    def messages(self, samples: Iterable[tuple[str, dict[str, Any]]]) -> list[tuple[str, Any]]:
        out: list[tuple[str, Any]] = []
        routes = self._routes
        for channel, sample in samples:
            if (route := routes.get(channel)) is not None:
                route(sample, out)
        return out

    def _board_attitude(self, attitude: dict[str, Any], _out: list[tuple[str, Any]]) -> None:
        self._board_rpy = attitude["rpy"]

    def _board_position(self, position: dict[str, Any], out: list[tuple[str, Any]]) -> None:
        if self._board_rpy is not None:
            stamp = timestamp(self.start_ns + position["t_us"] * 1000)
            out.append(("foxglove/tf", fm.FrameTransforms(transforms=[_transform(
                stamp, "ned", "board_estimate", position["pos_ned"], _quat(euler_to_quat(*self._board_rpy)))])))

    def _state_views(self, state: dict[str, Any], out: list[tuple[str, Any]]) -> None:
        t_us = state["t_us"]
        if t_us < self._next_us:
            return
        self._next_us = max(self._next_us + self._period_us, t_us)
        self._view_t_us = t_us
        stamp = timestamp(self.start_ns + t_us * 1000)
        transforms = fm.FrameTransforms(transforms=[
            fm.FrameTransform(timestamp=stamp, parent_frame_id="enu", child_frame_id="ned", translation=_ORIGIN,
                              rotation=_ENU_FROM_NED),
            _transform(stamp, "ned", "vehicle", state["pos_ned"], _quat(state["q_wxyz"]))])
        lat, lon, alt = self.frame.to_geodetic(*state["pos_ned"])
        fix = fm.LocationFix(timestamp=stamp, frame_id="vehicle", latitude=lat, longitude=lon, altitude=alt,
                             heading=state["rpy"][2], color=_TRUTH_COLOUR)
        out.append(("foxglove/tf", transforms))
        out.append(("foxglove/truth_fix", fix))

    def _reference_pose(self, ref: dict[str, Any], out: list[tuple[str, Any]]) -> None:
        if ref["t_us"] != self._view_t_us:
            return
        stamp = timestamp(self.start_ns + ref["t_us"] * 1000)
        pose = fm.Pose(position=_vec(ref["pos_ned"]), orientation=_quat(euler_to_quat(0.0, 0.0, ref["yaw"])))
        out.append(("foxglove/reference", fm.PoseInFrame(timestamp=stamp, frame_id="ned", pose=pose)))

    def _gps_fix(self, gps: dict[str, Any], out: list[tuple[str, Any]]) -> None:
        n, e, d = gps["vel_ned"]
        h, v = gps["eph_m"] ** 2, gps["epv_m"] ** 2
        out.append(("foxglove/gps", fm.LocationFix(
            timestamp=timestamp(self.start_ns + gps["t_us"] * 1000), frame_id="gps", latitude=gps["lat_deg"],
            longitude=gps["lon_deg"], altitude=gps["alt_msl_m"], position_covariance=[h, 0, 0, 0, h, 0, 0, 0, v],
            position_covariance_type=_DIAGONAL_KNOWN, velocity=fm.Vector3(x=e, y=n, z=-d), color=_GPS_COLOUR)))


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
