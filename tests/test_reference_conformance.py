"""Every member of the scenario's `reference:` union, through the same checks: a new type is covered by being
in the union. Its examples (the model's JSON-schema `examples`) are flown as a whole plan, take-off included,
and must be smooth where the vehicle follows them; the corners of its schema bounds must stay finite and
within the bench's limits.

Finite differences, with their tolerances derived from the step H. Position is C² and piecewise C³ (the
quintic segments' jerk jumps where they meet), so with J = sup‖jerk‖ Taylor's remainder gives
    ‖(x(t+H) − x(t−H)) / 2H − v(t)‖ ≤ H²·J/6,
and velocity, C¹ with a derivative that may jump, gives
    ‖(v(t+H) − v(t−H)) / 2H − a(t)‖ ≤ H·J/2,
each plus the rounding of the samples, δ/H with δ = 4 ulps of the largest value sampled (and of what the
rounding of t moves it by); H = 1 ms keeps that term well under the first (at 0.1 ms they are even). J comes
from the position alone: the third differences of x on a 10 ms grid are averages of the jerk, never above its
sup and, on segments much longer than the 30 ms they span, near it; J is twice their largest. The models'
examples land at half their velocity bound (the Taylor term at the sup) and under a third of their
acceleration bound. A jump of x, v or a where a check straddles it exceeds these bounds by orders of
magnitude (t = 0 and the take-off's end are checked).
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Callable, Iterator
from typing import Any, get_args

import numpy as np
import pytest
from pydantic import ValidationError

from hil.scenario.fields import MAX_DURATION_S, MAX_SPEED_M_S
from hil.scenario.mission import HOLD_BEFORE_S, MissionPlan
from hil.scenario.reference import Helix, Hover, Reference, RefSample
from hil.scenario.reference.base import ReferenceModel, time_warp
from hil.scenario.schema import Scenario
from hil.sensors.geodesy import MAX_DISTANCE_M

MEMBERS: tuple[type[ReferenceModel], ...] = get_args(get_args(Reference)[0])
H = 1e-3  # s, the finite-difference step
JERK_STEP_S = 0.01
CHECKED_TIMES = 1500  # grid points of the derivative checks over the plan, t = 0 and the take-off's end added
EXAMPLE_MISSION_S = 60.0
ULPS = 4 * np.finfo(float).eps
Sampler = Callable[[float], RefSample]


def tag(member: type[ReferenceModel]) -> str:
    return get_args(member.model_fields["type"].annotation)[0]


def examples(member: type[ReferenceModel]) -> list[dict[str, Any]]:
    return member.model_json_schema().get("examples", [])


EXAMPLES = [pytest.param(example, id=f"{tag(member)}-{i}") for member in MEMBERS
            for i, example in enumerate(examples(member))]


def plan_for(reference: dict[str, Any], duration_s: float = EXAMPLE_MISSION_S) -> MissionPlan:
    return MissionPlan.build(Scenario.model_validate({"name": "conformance", "duration_s": duration_s,
                                                      "reference": reference}))


def samples(sample: Sampler, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity, acceleration (n × 3) and yaw (n) at each time."""
    taken = [sample(float(t)) for t in times]
    return (np.array([s.pos_ned for s in taken]), np.array([s.vel_ned for s in taken]),
            np.array([s.acc_ned for s in taken]), np.array([s.yaw for s in taken]))


def largest_jerk(sample: Sampler, start: float, end: float) -> float:
    """J: twice the largest third difference of position on a JERK_STEP_S grid (module docstring)."""
    pos = samples(sample, np.arange(start - 3 * JERK_STEP_S, end + 3 * JERK_STEP_S, JERK_STEP_S))[0]
    return 2 * float(np.linalg.norm(np.diff(pos, n=3, axis=0), axis=1).max()) / JERK_STEP_S**3


def assert_derivatives(sample: Sampler, start: float, end: float, seams: tuple[float, ...] = ()) -> None:
    """v against the central difference of x, a against that of v, over [start, end] and at the seams."""
    times = np.union1d(np.linspace(start, end, CHECKED_TIMES), seams)
    after, before = times + H, times - H
    pos, vel, acc, _ = samples(sample, times)
    pos_after, vel_after, _, _ = samples(sample, after)
    pos_before, vel_before, _, _ = samples(sample, before)
    steps = (after - before)[:, None]
    jerk, largest_t = largest_jerk(sample, start, end), float(np.abs(times).max()) + H
    x_rounding = ULPS * (np.abs(pos).max() + np.abs(vel).max() * largest_t)
    v_rounding = ULPS * (np.abs(vel).max() + np.abs(acc).max() * largest_t)
    vel_error = np.linalg.norm((pos_after - pos_before) / steps - vel, axis=1)
    acc_error = np.linalg.norm((vel_after - vel_before) / steps - acc, axis=1)
    worst_v, worst_a = int(vel_error.argmax()), int(acc_error.argmax())
    assert vel_error[worst_v] <= H**2 * jerk / 6 + x_rounding / H, (
        f"velocity off the derivative of position by {vel_error[worst_v]:.3g} m/s at t = {times[worst_v]:g} s")
    assert acc_error[worst_a] <= H * jerk / 2 + v_rounding / H, (
        f"acceleration off the derivative of velocity by {acc_error[worst_a]:.3g} m/s² at t = {times[worst_a]:g} s")


def assert_flyable(sample: Sampler, times: np.ndarray) -> None:
    """Finite, yaw in (−π, π], within MAX_DISTANCE_M of home on each axis and at most MAX_SPEED_M_S."""
    pos, vel, acc, yaw = samples(sample, times)
    assert all(np.isfinite(v).all() for v in (pos, vel, acc, yaw)), "not finite"
    assert ((-math.pi < yaw) & (yaw <= math.pi)).all(), f"yaw {yaw[(yaw <= -math.pi) | (yaw > math.pi)][0]} rad"
    assert np.abs(pos).max() <= MAX_DISTANCE_M * (1 + ULPS), f"{np.abs(pos).max():g} m from home on one axis"
    assert np.linalg.norm(vel, axis=1).max() <= MAX_SPEED_M_S * (1 + ULPS), "faster than the bench's speeds"


@pytest.mark.parametrize("member", MEMBERS, ids=tag)
def test_every_member_builds_its_trajectory_and_shows_examples(member):
    assert issubclass(member, ReferenceModel)
    assert examples(member), f"{member.__name__} has no JSON-schema examples to be checked with"
    for example in examples(member):
        model = member.model_validate(example)
        assert model.type == tag(member) and callable(model.trajectory().sample)


@pytest.mark.parametrize("reference", EXAMPLES)
def test_the_reference_starts_at_rest_where_the_take_off_holds(reference):
    """Continuous at t = 0: the plan holds the start point, at rest, for HOLD_BEFORE_S before the mission clock
    starts; the reference begins there, at rest, facing the same way."""
    plan = plan_for(reference)
    held, start = plan.sample(-HOLD_BEFORE_S / 2), plan.sample(0.0)
    assert start.pos_ned == pytest.approx(held.pos_ned, rel=ULPS, abs=ULPS)
    assert np.abs(held.vel_ned).max() == 0 and np.abs(held.acc_ned).max() == 0
    assert np.abs(start.vel_ned).max() == 0 and np.abs(start.acc_ned).max() == 0
    assert start.yaw == held.yaw


@pytest.mark.parametrize("reference", EXAMPLES)
def test_velocity_and_acceleration_are_the_derivatives_over_the_whole_plan(reference):
    plan = plan_for(reference)
    assert_derivatives(plan.sample, -plan.takeoff_s - 1.0, plan.duration_s, seams=(0.0, -HOLD_BEFORE_S))


@pytest.mark.parametrize("reference", EXAMPLES)
def test_the_plan_is_finite_wrapped_and_within_the_benchs_limits(reference):
    plan = plan_for(reference)
    assert_flyable(plan.sample, np.linspace(-plan.takeoff_s, plan.duration_s, 2000))


def corners(schema: dict[str, Any]) -> list[Any]:
    """The extreme values a JSON-schema property allows: a number's bounds (the largest float where it has
    none), a fixed tuple's items all at one bound, null where allowed; [] for anything else (lists)."""
    if "anyOf" in schema:
        return [value for branch in schema["anyOf"] for value in corners(branch)]
    if schema.get("type") == "null":
        return [None]
    if schema.get("type") in ("number", "integer"):
        low = schema.get("minimum", math.nextafter(schema.get("exclusiveMinimum", -math.inf), math.inf))
        high = schema.get("maximum", math.nextafter(schema.get("exclusiveMaximum", math.inf), -math.inf))
        low, high = max(low, -sys.float_info.max), min(high, sys.float_info.max)
        return [math.ceil(low), math.floor(high)] if schema["type"] == "integer" else [low, high]
    if schema.get("type") == "array" and "prefixItems" in schema:
        per_item = [corners(item) for item in schema["prefixItems"]]
        return [[values[i] for values in per_item] for i in range(2)]
    return []


def corner_references(member: type[ReferenceModel]) -> Iterator[dict[str, Any]]:
    """The first example with every bounded field at each of its extremes, in every combination."""
    properties = member.model_json_schema()["properties"]
    extremes = {name: values for name, prop in properties.items() if (values := corners(prop))}
    for combination in itertools.product(*extremes.values()):
        yield {**examples(member)[0], **dict(zip(extremes, combination, strict=True))}


@pytest.mark.parametrize("member", MEMBERS, ids=tag)
def test_every_corner_the_schema_accepts_stays_finite_and_within_the_benchs_limits(member):
    """A scenario the schema accepts must fly a finite reference within the bench's distances and speeds, at
    the bounds of every field at once, over a short mission and the longest."""
    accepted = 0
    for reference, duration_s in itertools.product(corner_references(member), (EXAMPLE_MISSION_S, MAX_DURATION_S)):
        try:
            plan = plan_for(reference, duration_s)
        except ValidationError:  # refused as the file loads: nothing to fly
            continue
        accepted += 1
        assert_flyable(plan.sample, np.union1d(np.linspace(-plan.takeoff_s, duration_s, 200), 0.0))
    assert accepted > 0


def test_the_checks_fail_for_a_reference_that_breaks_them():
    """The checks above can fail: a helix whose smooth start applies the chain rule by half (acceleration
    without the τ̈ term, or velocity without τ̇), and a yaw of 4 rad."""
    helix = Helix(ramp_s=2.0)

    def along_tau(t: float) -> tuple[RefSample, np.ndarray, float, float]:
        """The sample, d(position)/dτ (the unwarped helix's velocity at τ), τ̇ and τ̈."""
        tau, rate, rate_dot = time_warp(t, helix.ramp_s)
        return helix.sample(t), Helix(ramp_s=0.0).sample(tau).vel_ned, rate, rate_dot

    def without_rate_dot(t: float) -> RefSample:
        r, dpos, _, rate_dot = along_tau(t)
        return RefSample(r.pos_ned, r.vel_ned, r.acc_ned - dpos * rate_dot, r.yaw)

    def without_rate(t: float) -> RefSample:
        r, dpos, _, _ = along_tau(t)
        return RefSample(r.pos_ned, dpos, r.acc_ned, r.yaw)

    assert_derivatives(helix.sample, 0.0, 5.0)
    with pytest.raises(AssertionError, match="acceleration off"):
        assert_derivatives(without_rate_dot, 0.0, 5.0)
    with pytest.raises(AssertionError, match="velocity off"):
        assert_derivatives(without_rate, 0.0, 5.0)
    with pytest.raises(AssertionError, match="yaw 4"):
        assert_flyable(Hover((0.0, 0.0, -5.0), yaw=4.0).sample, np.linspace(0.0, 1.0, 5))
