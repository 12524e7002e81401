"""`check_expectations` and `Expect.for_board`: each bound against figures on both sides of it."""

from __future__ import annotations

from hil.judge.metrics import check_expectations
from hil.scenario.schema import Expect


def axes(x: float, y: float, z: float) -> dict:
    return {a: {"max_abs": v} for a, v in zip("xyz", (x, y, z), strict=True)}


def figures(pos=(0.1, 0.1, 0.1), roll=1.0, pitch=1.0, rtf=10.0) -> dict:
    return {"position_error_m": axes(*pos), "timing": {"realtime_factor": rtf},
            "attitude_error_deg": {"roll": {"max_abs": roll}, "pitch": {"max_abs": pitch}, "yaw": {"max_abs": 50}}}


def test_no_expectations_fail_nothing():
    assert check_expectations(None, {}) == []


def test_a_bound_on_all_axes_or_per_axis_names_the_axis_that_breaks_it():
    assert check_expectations(Expect(max_error_m=0.5), figures(pos=(0.5, 0.49, 0.1))) == []
    (one,) = check_expectations(Expect(max_error_m=0.5, settle_s=3), figures(pos=(0.1, 0.51, 0.1)))
    assert one == "max |e_y| = 0.510 m after 3 s, expected ≤ 0.5 m"
    per_axis = check_expectations(Expect(max_error_m=(1.0, 1.0, 0.2)), figures(pos=(0.9, 1.2, 0.3)))
    assert [line.split(" = ")[0] for line in per_axis] == ["max |e_y|", "max |e_z|"]


def test_the_attitude_bound_is_on_roll_and_pitch_only():
    """Yaw is not in the bound (a heading error of 50° here does not fail it)."""
    assert check_expectations(Expect(max_attitude_error_deg=2.0), figures(roll=1.9, pitch=2.0)) == []
    (one,) = check_expectations(Expect(max_attitude_error_deg=2.0), figures(roll=0.5, pitch=2.5))
    assert one == "max roll/pitch error = 2.50°, expected ≤ 2°"


def test_missing_figures_fail_with_the_reason_instead_of_passing():
    empty = {"timing": {"realtime_factor": None}}
    failures = check_expectations(Expect(max_error_m=1.0, max_attitude_error_deg=3.0, min_realtime_factor=1.0),
                                  empty)
    assert failures == ["no settled mission samples to check the position error",
                        "the board reported no commanded attitude (ATTITUDE_TARGET) to check against",
                        "real-time factor = 0.00, expected ≥ 1"]


def test_px4_bounds_replace_only_the_bounds_they_state():
    expect = Expect(max_error_m=0.3, max_attitude_error_deg=2.0, px4={"max_error_m": 1.0})
    assert expect.for_board(px4=False) is expect
    px4 = expect.for_board(px4=True)
    assert px4.max_error_m == 1.0 and px4.max_attitude_error_deg == 2.0
    assert check_expectations(px4, figures(pos=(0.8, 0.8, 0.8))) == []
    assert check_expectations(expect, figures(pos=(0.8, 0.8, 0.8))) != []
