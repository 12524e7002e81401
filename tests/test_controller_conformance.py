"""Every registered controller, and the template a new one starts from, against the plug-in contract
(docs: CONTRIBUTING.md, "Adding a controller"): equilibrium and sign facts derived by hand, the names
the wire and the parameter protocol carry, and a hover on the real plant FMU."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_interface.emulator.config import build_config
from firmware_interface.emulator.control import Nominal, Setpoint, VehicleState
from firmware_interface.emulator.control import template as template_module
from firmware_interface.emulator.control.plugin import ControllerPlugin
from firmware_interface.emulator.control.registry import (
    DEBUG_NAME_LENGTH,
    PLUGINS,
    make_controller,
    wire_name,
)
from tests.support.closed_loop import fly, hover

G = 9.80665  # standard gravity, m/s²
NOMINAL = Nominal(1.0, np.array((0.011, 0.011, 0.021)), G)  # the inspection quad's nominal vehicle
DT = 0.004
ALL = [*PLUGINS.values(), template_module.PLUGIN]
DEBUG_FLOAT_ARRAY_SLOTS = 58  # MAVLink DEBUG_FLOAT_ARRAY.data is float[58]
PARAM_ID_CHARS = 16  # MAVLink PARAM_VALUE.param_id is char[16]


def at_rest(pos_ned=(0.0, 0.0, -5.0)) -> VehicleState:
    return VehicleState(np.array(pos_ned, dtype=float), np.zeros(3), np.zeros(3), np.zeros(3))


def hold(pos_ned=(0.0, 0.0, -5.0)) -> Setpoint:
    return Setpoint(np.array(pos_ned, dtype=float), np.zeros(3), np.zeros(3), 0.0)


@pytest.fixture(params=ALL, ids=lambda p: p.name)
def plugin(request) -> ControllerPlugin:
    return request.param


def test_at_the_setpoint_a_level_vehicle_gets_its_weight_in_thrust_and_no_torque(plugin):
    controller = plugin.build(NOMINAL, plugin.gains())
    for _ in range(20):
        out = controller.update(at_rest(), hold(), DT)
    assert out.thrust_n == pytest.approx(NOMINAL.mass * G, rel=1e-6)  # u1 = m g, level
    assert np.abs(out.torque_frd).max() < 1e-9 and np.abs(out.eta_cmd).max() < 1e-9


def test_errors_command_the_way_back(plugin):
    """NED/FRD signs, by hand: 1 m low (z larger) -> more than m g; north of the setpoint -> the thrust
    must tilt south, nose up (pitch > 0); east of it -> tilt west, left wing down (roll < 0)."""
    build = lambda: plugin.build(NOMINAL, plugin.gains())  # noqa: E731 - a fresh controller per case
    low = build().update(at_rest((0.0, 0.0, -4.0)), hold(), DT)
    north = build().update(at_rest((1.0, 0.0, -5.0)), hold(), DT)
    east = build().update(at_rest((0.0, 1.0, -5.0)), hold(), DT)
    assert low.thrust_n > NOMINAL.mass * G
    assert north.eta_cmd[1] > math.radians(0.5) and abs(north.eta_cmd[0]) < 1e-9
    assert east.eta_cmd[0] < -math.radians(0.5) and abs(east.eta_cmd[1]) < 1e-9


def test_reset_makes_the_next_flight_repeat_the_first(plugin):
    controller = plugin.build(NOMINAL, plugin.gains())
    states = [at_rest((0.3 * math.sin(k / 7), 0.2, -5.0 + 0.1 * k / 50)) for k in range(50)]

    def flight() -> list[tuple[float, ...]]:
        return [(out.thrust_n, *out.torque_frd, *out.eta_cmd)
                for out in (controller.update(s, hold(), DT) for s in states)]

    first = flight()
    controller.reset()
    assert flight() == first


def test_its_internals_and_names_fit_the_messages_that_carry_them(plugin):
    keys = plugin.controller.internal_keys
    out = plugin.build(NOMINAL, plugin.gains()).update(at_rest((0.5, 0.0, -5.0)), hold(), DT)
    assert len(set(keys)) == len(keys) <= DEBUG_FLOAT_ARRAY_SLOTS
    assert set(out.internals) == set(keys) and all(math.isfinite(v) for v in out.internals.values())
    assert plugin.name == plugin.controller.name and plugin.name.isidentifier()
    assert set(plugin.runtime_gains) <= set(plugin.gains.model_fields)
    names = {f"{plugin.param_prefix}_{gain.upper()}"[:PARAM_ID_CHARS] for gain in plugin.runtime_gains}
    assert len(names) == len(plugin.runtime_gains)  # still one parameter per gain once cut to 16 characters


def test_registered_names_stay_apart_on_the_wire():
    """DEBUG_FLOAT_ARRAY keeps 10 characters of the name and PARAM_VALUE 16 of a parameter's."""
    wire = [wire_name(name) for name in PLUGINS]
    assert len(set(wire)) == len(wire) and all(len(w) <= DEBUG_NAME_LENGTH for w in wire)
    params = [f"{p.param_prefix}_{g.upper()}"[:PARAM_ID_CHARS] for p in PLUGINS.values() for g in p.runtime_gains]
    assert len(set(params)) == len(params)


def test_the_configuration_builds_each_registered_controller_with_its_own_gains():
    for name, plugin in PLUGINS.items():
        config = build_config({"controller": name})
        controller = make_controller(config)
        assert controller.name == name and isinstance(getattr(config.gains, name), plugin.gains)


def test_it_hovers_on_the_plant_fmu_from_an_offset_start(plugin):
    config = build_config({})  # the inspection quad on the true state, with its airframe's gains (if it has any)
    controller = plugin.build(NOMINAL, getattr(config.gains, plugin.name, None) or plugin.gains())
    trace = fly(config, {}, hover((0.0, 0.0, -10.0)), 8.0, start=(0.5, -0.3, -9.5), controller=controller)
    settled = trace.t > 5.0
    assert np.abs(trace.pos[0] - trace.ref[0]).max() > 0.4  # it really started off the setpoint
    assert np.abs(trace.pos[settled] - trace.ref[settled]).max() < 0.05


def test_a_runtime_gain_swapped_in_flight_takes_effect_at_the_next_step(plugin):
    """A PARAM_SET replaces the frozen gains model (emulator/params.py); the step must read the new one, not a copy
    packed before (`base.GainValues`)."""
    gain = plugin.runtime_gains[0]
    swapped, kept = plugin.build(NOMINAL, plugin.gains()), plugin.build(NOMINAL, plugin.gains())
    for _ in range(3):
        swapped.update(at_rest((0.5, -0.4, -4.5)), hold(), DT)
        kept.update(at_rest((0.5, -0.4, -4.5)), hold(), DT)
    swapped.gains = swapped.gains.model_copy(update={gain: 2 * getattr(swapped.gains, gain)})
    after, unchanged = (c.update(at_rest((0.5, -0.4, -4.5)), hold(), DT) for c in (swapped, kept))
    assert after.thrust_n != unchanged.thrust_n or not np.array_equal(after.eta_cmd, unchanged.eta_cmd)
