"""A minimal PX4-like board for board-session tests: real MAVLink bytes over a pty, scripted answers."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

from firmware_interface import hil_codec as codec
from firmware_interface.link import Link, LinkLost, open_pty_pair
from firmware_interface.link.transports import SerialTransport


@dataclass
class ScriptedBoard:
    """Answers like PX4 SITL: one HIL_ACTUATOR_CONTROLS per HIL_SENSOR after `free_run` sensors."""

    free_run: int = 5
    accept_arm: bool = True
    send_heartbeat: bool = True
    answer_sensors: bool = True
    stall_s: float = 0.0  # silent this long before answering the next HIL_SENSOR (once): a board off its CPU
    # not None: the first answer is held until the next HIL_SENSOR comes, and that one's goes this much later
    # (replies lagging a step behind the bench's free-run waits, as on a loaded machine)
    lag_first_answers_s: float | None = None
    received: list[str] = field(default_factory=list)
    messages: dict[str, Any] = field(default_factory=dict)  # the last message of each kind, decoded
    armed: bool = False
    params: dict[str, tuple[float, int]] = field(default_factory=dict)  # as PX4 keeps them: the field's value, type

    def start(self) -> Link:
        pair = open_pty_pair()
        self.link = Link(SerialTransport(pair.slave_path), system_id=1, component_id=1)
        pair.release_slave()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return Link(pair.master)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.link.close()

    def _run(self) -> None:
        sensors = 0
        beat = 0
        held: Any = None  # a HIL_SENSOR whose answer waits for the next (`lag_first_answers_s`)
        try:
            while not self._stop.is_set():
                beat += 1
                if self.send_heartbeat and beat % 10 == 1:
                    self.link.send("HEARTBEAT", type=2, autopilot=12, base_mode=32 | (128 if self.armed else 0),
                                   custom_mode=0, system_status=4, mavlink_version=3)
                for msg in self.link.receive(0.01):
                    kind = msg.get_type()
                    self.received.append(kind)
                    self.messages[kind] = msg
                    if kind == "HIL_SENSOR" and self.answer_sensors:
                        time.sleep(self.stall_s)
                        self.stall_s = 0.0
                        sensors += 1
                        if sensors <= self.free_run:
                            continue
                        if self.lag_first_answers_s is not None:
                            if held is None:
                                held = msg
                                continue
                            self._answer(held)
                            time.sleep(self.lag_first_answers_s)
                            self.lag_first_answers_s = None
                        self._answer(msg)
                    elif kind == "PARAM_SET":  # PX4 keeps the field's four bytes and sends them back, typed
                        self.params[msg.param_id] = (msg.param_value, msg.param_type)
                        self.link.send("PARAM_VALUE", param_id=msg.param_id, param_value=msg.param_value,
                                       param_type=msg.param_type, param_count=len(self.params), param_index=0)
                    elif kind == "COMMAND_LONG":
                        ok = msg.command != 400 or self.accept_arm
                        if ok and msg.command == 400:
                            self.armed = msg.param1 == 1.0
                        self.link.send("COMMAND_ACK", command=msg.command, result=0 if ok else 4, progress=0,
                                       result_param2=0, target_system=msg.get_srcSystem(),
                                       target_component=msg.get_srcComponent())
        except LinkLost:
            return

    def _answer(self, sensor: Any) -> None:
        fields = codec.hil_actuator_controls_fields(sensor.time_usec, (0.5,) * 4, self.armed, True)
        self.link.send_fields("HIL_ACTUATOR_CONTROLS", fields)
