"""A lockstep reply PX4 SITL sent and the bench never read: PX4 then waits for the next HIL_SENSOR and the bench
for the reply, the state in which PX4 v1.15.4 itself now and then drops a reply on a loaded machine (its console:
"poll timeout 0, 22"; the watchdog ended those flights). The bench sees PX4's threads all asleep, steps on with its
last outputs, and the flight flies on to its end with the step it stepped past in the summary."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from firmware_interface.actuator_reply import ActuatorReader
from firmware_interface.board_dropped_reply import DROPPED_AFTER_S, LOOK_SPAN_S
from firmware_interface.link import Message
from hil.boards.handle import BoardHandle
from hil.boards.px4 import Px4Build
from hil.boards.px4_sitl import Px4SitlTarget
from hil.boards.target import BoardPolicy, LinkSettings
from hil.exit_codes import EXIT_OK
from hil.loop.frame import StepFrame
from hil.loop.sink import FrameSink
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario
from hil.scenario.schema import Scenario

pytestmark = [pytest.mark.px4, pytest.mark.slow]

LOST_AT_US = 6_000_000  # PX4's reply to the first step from here on is lost: armed and climbing by then
WATCHDOG_S = 1.0


@dataclass
class Px4LosingOneReply:
    """PX4 SITL whose HIL link loses PX4's first HIL_ACTUATOR_CONTROLS for a step at or after LOST_AT_US."""

    target: Px4SitlTarget
    monkeypatch: pytest.MonkeyPatch
    lost_us: list[int] = field(default_factory=list)

    @property
    def label(self) -> str:
        return self.target.label

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return self.target.policy(scenario)

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        """The reply is lost whichever way the link reads it: alone in a read (the session's whole-frame reader,
        which then takes it and does nothing with it) or among other frames (the scanner's messages)."""
        handle = self.target.attach(scenario, run_dir, settings)
        link = handle.hil_session.link
        receive, read_whole, replies = link.receive, link.whole_frame_reader, ActuatorReader()
        assert read_whole is not None

        def losing_one(timeout_s: float) -> list[Message]:
            messages = receive(timeout_s)
            for message in messages:
                if (not self.lost_us and message.get_type() == "HIL_ACTUATOR_CONTROLS"
                        and message.time_usec >= LOST_AT_US):
                    self.lost_us.append(message.time_usec)
                    return [m for m in messages if m is not message]
            return messages

        def losing_one_alone(data: bytes) -> tuple[int, ...]:
            reply = None if self.lost_us else replies.read(data)
            if reply is not None and reply.t_us >= LOST_AT_US:
                self.lost_us.append(reply.t_us)
                return (len(data),)
            return read_whole(data)

        self.monkeypatch.setattr(link, "receive", losing_one)
        self.monkeypatch.setattr(link, "whole_frame_reader", losing_one_alone)
        return handle


def test_a_reply_px4_never_gets_read_is_stepped_past_and_the_flight_flies_to_its_end(sitl, tmp_path, monkeypatch):
    scenario_path = tmp_path / "short_hover.yaml"
    scenario_path.write_text("name: short_hover\nduration_s: 3\nseed: 1\nreference: {type: hover, altitude_m: 3}\n")
    board = Px4LosingOneReply(Px4SitlTarget(Px4Build.locate(sitl, "--px4")), monkeypatch)
    frames: list[StepFrame] = []
    outcome = run_scenario(load_scenario(scenario_path),
                           RunOptions(board=board, runs_root=tmp_path / "runs", telemetry=None, gcs=[],
                                      watchdog_s=WATCHDOG_S), [FrameSink(frames.append)])
    assert (outcome.exit_code, outcome.reason) == (EXIT_OK, "completed"), outcome.reason
    (lost_us,) = board.lost_us
    dropped = json.loads((outcome.run_dir / "metrics.json").read_text())["timing"]["lockstep_replies_dropped"]
    assert dropped == {"count": 1, "at_s": [lost_us / 1e6]}
    (stepped_past,) = [f for f in frames if f.t_us == lost_us]
    # waited for the reply, then for PX4 idle over a span, and not for the watchdog
    assert DROPPED_AFTER_S + LOOK_SPAN_S <= stepped_past.step_wall_s < WATCHDOG_S
    after = [f for f in frames if f.t_us > lost_us]
    assert len(after) > 1000 and all(f.round_trip_s is not None for f in after[:250])  # PX4 answered on, in lockstep
    assert not after[-1].armed  # landed and disarmed: the whole flight
    assert "lockstep replies the board dropped: 1" in (outcome.run_dir / "summary.txt").read_text()
