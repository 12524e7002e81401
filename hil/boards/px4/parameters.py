"""What a PX4 the bench started is told about the simulated vehicle, as a user configures a real one."""

from __future__ import annotations

from hil.scenario.plant import RotorGeometry
from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve

# MAVLink's MAV_TYPE of a multirotor by its rotor count (tricopter, quad, hexa, octo, dodeca)
MAV_TYPES = {3: 15, 4: 2, 6: 13, 8: 14, 12: 29}
MOTOR_1 = 101  # PX4's output function Motor1 (Motor i is 100 + i)


def px4_parameters(scenario: Scenario, rotors: RotorGeometry | None) -> dict[str, float | int]:
    """EKF2_GPS_DELAY (ms) is the receiver's delay (PX4 SITL's own default of 10 ms assumes a delay-free
    simulator GPS); the plant's rotors, if the run gives them, are PX4's control allocation."""
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    params: dict[str, float | int] = {"EKF2_GPS_DELAY": round(gps.delay_s * 1000.0, 3)}
    return params | (rotor_parameters(rotors) if rotors is not None else {})


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
