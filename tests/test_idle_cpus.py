"""Idle CPUs kept polling while a run flies: the PM QoS request on /dev/cpu_dma_latency, checked against the kernel's
own figures (the combined request it reads back, the bench's open files in /proc) rather than the bench's word."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest

from hil.host.idle_cpus import CPU_DMA_LATENCY, CPUIDLE_DRIVER, cpuidle_driver, idle_cpus_polling
from hil.loop.frame import StepFrame
from hil.loop.sink import FrameSink
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario

needs_the_device = pytest.mark.skipif(not os.access(CPU_DMA_LATENCY, os.W_OK),
                                      reason=f"{CPU_DMA_LATENCY} not writable here (needs root)")
# what the kernel does with the request here: only a cpuidle driver heeds it (read from sysfs, not the bench's word)
HEEDED = cpuidle_driver() != "none"


def no_driver_note(driver: Path = CPUIDLE_DRIVER) -> str:
    return f"sleeping: the kernel has no cpuidle driver ({driver}: none), so idle CPUs halt whatever is asked"


def combined_request_us() -> int:
    """What the kernel allows idle CPUs now, every process's request combined (reading the device gives it)."""
    with open(CPU_DMA_LATENCY, "rb") as device:
        return int(struct.unpack("=i", device.read(4))[0])


def holds_the_device() -> bool:
    """Whether this process has the device open: the kernel drops a request when its file closes."""
    fds = Path("/proc/self/fd")
    return any(os.path.realpath(fds / fd) == str(CPU_DMA_LATENCY) for fd in os.listdir(fds))


@needs_the_device
def test_the_request_holds_zero_while_the_block_runs_and_is_dropped_after():
    """Where the kernel has no cpuidle driver (this project's Firecracker VMs at times) nothing is held or claimed."""
    assert not holds_the_device()
    with idle_cpus_polling() as note:
        if HEEDED:
            assert combined_request_us() == 0 and holds_the_device()
            assert note == f"polling ({CPU_DMA_LATENCY} held at 0 us)"
        else:
            assert not holds_the_device() and note == no_driver_note()
    assert not holds_the_device()
    with idle_cpus_polling("--power-save") as note:
        assert not holds_the_device() and note == "sleeping (--power-save)"


def test_a_kernel_without_a_cpuidle_driver_is_not_asked_and_the_run_says_so(tmp_path):
    driver = tmp_path / "current_driver"
    driver.write_text("none\n")
    with idle_cpus_polling(None, CPU_DMA_LATENCY, driver) as note:
        assert not holds_the_device()
        assert note == no_driver_note(driver)
    with idle_cpus_polling(None, CPU_DMA_LATENCY, tmp_path / "no_cpuidle_at_all") as note:
        assert not holds_the_device() and note.startswith("sleeping: the kernel has no cpuidle driver")


def test_a_device_that_cannot_be_opened_leaves_the_cpus_as_they_are_and_says_why(tmp_path):
    missing = tmp_path / "no_such_device"
    driver = tmp_path / "current_driver"
    driver.write_text("haltpoll\n")  # a driver that would heed it
    with idle_cpus_polling(None, missing, driver) as note:
        assert note == f"sleeping: {missing} not writable (No such file or directory; needs root)"
    assert not missing.exists()


@needs_the_device
@pytest.mark.e2e
@pytest.mark.parametrize(("power_save", "realtime"), [(False, False), (True, False), (False, True)])
def test_a_lockstep_run_holds_the_request_for_every_step_unless_told_to_save_power(tmp_path, power_save, realtime):
    """A paced run (here `--realtime`) leaves the CPUs as they are: its worst wake-up is what counts."""
    scenario_path = tmp_path / "hold.yaml"
    scenario_path.write_text("name: hold\nduration_s: 0.5\nseed: 5\nend: disarm\n"
                             "reference: {type: hover, altitude_m: 1}\n")
    seen: list[tuple[bool, int]] = []

    def look(frame: StepFrame) -> None:
        seen.append((holds_the_device(), combined_request_us()))

    outcome = run_scenario(load_scenario(scenario_path),
                           RunOptions(runs_root=tmp_path / "runs", telemetry=None, gcs=[],
                                      idle_cpus_poll=not power_save, realtime=realtime), [FrameSink(look)])
    assert outcome.exit_code == 0, outcome.reason
    assert len(seen) > 100  # every step of the flight was looked at
    if power_save or realtime or not HEEDED:
        assert not any(held for held, _ in seen)
        assert outcome.metrics["timing"]["idle_cpus"] == (
            "sleeping (--power-save)" if power_save
            else "sleeping (a paced run: its worst wake-up counts more than its typical one)" if realtime
            else no_driver_note())
    else:
        assert seen == [(True, 0)] * len(seen)
        assert outcome.metrics["timing"]["idle_cpus"].startswith("polling")
        assert "idle CPUs: polling" in outcome.summary
    assert not holds_the_device()  # released with the run
