"""What a PX4 the bench started is told about the simulated vehicle, as a user configures a real one: the plant's
rotors at start-up (its start-up script sets them after the airframe's defaults, before any module starts), and
every parameter again through PARAM_SET, read back before arming."""

from __future__ import annotations

from pathlib import Path

from hil.scenario.failsafe import px4_parameter_values
from hil.scenario.plant import RotorGeometry
from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve

# MAVLink's MAV_TYPE of a multirotor by its rotor count (tricopter, quad, hexa, octo, dodeca)
MAV_TYPES = {3: 15, 4: 2, 6: 13, 8: 14, 12: 29}
MOTOR_1 = 101  # PX4's output function Motor1 (Motor i is 100 + i)


def px4_parameters(scenario: Scenario, rotors: RotorGeometry | None) -> dict[str, float | int]:
    """EKF2_GPS_DELAY (ms) is the receiver's delay (PX4 SITL's own default of 10 ms assumes a delay-free
    simulator GPS); the plant's rotors, if the run gives them, are PX4's control allocation; the scenario's
    `board.params` (failsafe actions and thresholds) as they are."""
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    params: dict[str, float | int] = {"EKF2_GPS_DELAY": round(gps.delay_s * 1000.0, 3)}
    return params | (rotor_parameters(rotors) if rotors is not None else {}) | px4_parameter_values(
        scenario.board.params) | battery_parameters(scenario)


# PX4 v1.15.4 publishes a MAVLink BATTERY_STATUS with time_remaining_s left at 0 (mavlink_receiver.cpp
# handle_message_battery_status: `battery_status_s battery_status{}`, the field never set), and its battery check
# reads that as no flight time left: once the RTL time estimate is valid (in the air) battery_low_remaining_time is
# set (batteryCheck.cpp rtlEstimateCheck). With COM_FLTT_LOW_ACT 3 (PX4's default) the vehicle returned 1 s after
# take-off; with 0 PX4 still held 5 s in AUTO.LOITER and resumed; with 1 it only warns ("Failsafe activated",
# no mode change), and the charge's own levels (BAT_*_THR, COM_LOW_BAT_ACT) act as they should.
EXTERNAL_BATTERY = {"COM_FLTT_LOW_ACT": 1}  # warning


def battery_parameters(scenario: Scenario) -> dict[str, float | int]:
    """What PX4 needs to fly on the bench's battery (`battery:`): the remaining-flight-time failsafe only warns."""
    return dict(EXTERNAL_BATTERY) if scenario.battery is not None else {}


def sitl_start_parameters(scenario: Scenario, rotors: RotorGeometry | None) -> dict[str, float | int]:
    """What PX4 SITL's start-up sets before its modules start: the plant's rotors, the scenario's `board.params`, and
    with a `battery:` section `battery_parameters` and SIM_BAT_ENABLE 0, so that SITL's rcS does not start its
    battery_simulator, whose battery_status would fight the bench's (mavlink_receiver publishes BATTERY_STATUS on
    the same topic)."""
    params = (rotor_parameters(rotors) if rotors is not None else {}) | px4_parameter_values(scenario.board.params)
    return params | battery_parameters(scenario) | ({"SIM_BAT_ENABLE": 0} if scenario.battery is not None else {})


def param_set_lines(params: dict[str, float | int]) -> str:
    """`param set` lines for PX4's start-up shell, every value in full (repr)."""
    return "".join(f"param set {name} {value!r}\n" for name, value in params.items())


def write_sitl_start_parameters(folder: Path, params: dict[str, float | int]) -> Path:
    """`px4-rc.params` in `folder`, which PX4 SITL's rcS sources after the airframe ("user defined params for
    instances can be in PATH": put `folder` first on PX4's PATH) and before it starts its modules. Set there, the
    rotors are in place before the control allocator and the output driver start; set only while PX4 runs, a change
    of an output's function was once seen not to reach `pwm_out_sim` before arming (motors 5 and 6 silent), which
    it then defers."""
    path = folder / "px4-rc.params"
    path.write_text("#!/bin/sh\n# Written by hil-bench: the plant and the scenario on PX4 SITL's airframe\n"
                    + param_set_lines(params))
    return path


def rotor_parameters(rotors: RotorGeometry) -> dict[str, float | int]:
    """The plant's rotors on the airframe PX4 SITL starts with (10016, a quad): its control allocation
    (CA_ROTOR_COUNT, CA_ROTORi_PX/PY/PZ/KM, read again on each parameter change), rotor i's output on PWM_MAIN_FUNCi
    (SITL's pwm_out_sim reads the PWM_MAIN prefix; HITL on a Pixhawk, HIL_ACT), and MAV_TYPE. INT32 parameters
    are ints (PX4 refuses a PARAM_SET of another type)."""
    params: dict[str, float | int] = {name: (int(value) if name == "CA_ROTOR_COUNT" else value)
                                      for name, value in rotors.px4_parameters().items()}
    params |= {f"PWM_MAIN_FUNC{i}": MOTOR_1 + i - 1 for i in range(1, rotors.count + 1)}
    if rotors.count in MAV_TYPES:
        params["MAV_TYPE"] = MAV_TYPES[rotors.count]
    return params
