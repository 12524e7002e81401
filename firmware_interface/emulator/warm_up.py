"""Compile the flight code before the board answers: a few steps of the configured estimator, controller,
mixer and reply frames on a vehicle at rest, in process, with nothing sent.

Compiling a law takes seconds the first time on a machine (later only loading it from the cache, ~0.1 s).
Done at the first HIL_SENSOR instead, it would stall the first steps past the bench's lockstep watchdog; done
here, it delays only the first heartbeat, which the bench waits for. Afterwards compiling is switched off:
an argument of a type never seen would otherwise compile silently in the middle of a flight, and now fails
at once, naming the function.
"""

from __future__ import annotations

import sys

import numpy as np

from firmware_interface.emulator import reply_frames, step_read
from firmware_interface.emulator.compiled import FLIGHT_CODE
from firmware_interface.emulator.config import EmulatorConfig, build_config
from firmware_interface.emulator.control import Setpoint, VehicleState
from firmware_interface.emulator.control.registry import CONTROLLERS, make_controller
from firmware_interface.emulator.estimator import Estimator
from firmware_interface.emulator.mixer import Mixer
from firmware_interface.emulator.reply_frames import ReplyBuffers, pack_reply
from firmware_interface.emulator.trajectory import quintic_sample
from firmware_interface.emulator.truth import OdometryReader
from firmware_interface.hil_codec import Baro, GpsFix, SensorReadings
from firmware_interface.link import frame_scan

STEP_US = 4000


def compile_flight_code(config: EmulatorConfig) -> None:
    """Every compiled function the board will call, called once with the types a flight gives it; then no more
    compiling."""
    exercise_flight_code(config)
    frame_scan.warm_up()  # the bench's frames are read through it
    FLIGHT_CODE.freeze()
    frame_scan.FRAME_SCAN.freeze()


def exercise_flight_code(config: EmulatorConfig) -> None:
    """Every compiled function a flight with `config` calls, called once (compiled or loaded from the cache)."""
    g = config.vehicle.g
    estimator = Estimator(config.estimator, g)
    estimator.on_gps(GpsFix(0, 47.4, 8.5, 500.0, (0.0, 0.0, 0.0), 1.0, 1.0), 0)  # the origin and the field
    field, origin = estimator.field_ned, estimator.origin
    assert field is not None and origin is not None
    for k in range(1, 4):  # align, then attitude, propagation and baro
        estimator.on_sensors(SensorReadings(k * STEP_US, (0.0, 0.0, -g), (0.0, 0.0, 0.0), tuple(field.tolist()),
                                            Baro(95000.0, 15.0, 500.0)))
    e = estimator.estimate()
    state = VehicleState(e.pos_ned, e.vel_ned, e.eta, e.rates_frd)
    setpoint = Setpoint(e.pos_ned.copy(), np.zeros(3), np.zeros(3), 0.0)
    controller = make_controller(config)
    for _ in range(2):  # the differentiator starts on the first, steps on the second
        out = controller.update(state, setpoint, STEP_US * 1e-6)
    controller.reset()
    motors = Mixer(config.vehicle).commands(out.thrust_n, out.torque_frd)
    reply = ReplyBuffers(controller.name)
    reply.origin[:] = origin.constants
    for flags in (0, reply_frames.EVERY_FRAME):
        pack_reply(reply.frames, reply.ends, reply.link, flags, STEP_US, 0, e.pos_ned, e.vel_ned, e.eta, e.rates_frd,
                   reply.origin, reply.home_d, reply.eta_cmd, reply.thrust, reply.debug, reply.debug_name, motors)
    quintic_sample(np.zeros((3, 6)), 0.0)  # the navigator's moves
    OdometryReader().exercise()  # the true state (state_source truth)
    step_read.warm_up()  # the bench's lockstep reads


def main() -> int:
    """`python -m firmware_interface.emulator.warm_up`: compile every controller's flight code into the cache
    (the setup step of `make`), so that no run pays for it."""
    for controller in CONTROLLERS:
        compile_flight_code(build_config({"controller": controller}))
    print(f"flight code compiled for {', '.join(CONTROLLERS)} in {FLIGHT_CODE.cache_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
