"""The startup script for PX4's HITL code path on a posix build, written by the bench per run.

On a flight controller, NuttX's `init.d/rcS` has a branch for SYS_HITL=1; PX4's posix `rcS` has
none (it always starts the SITL simulator modules). A `px4_sitl_nolockstep` build started with
this script instead runs what the flight controller runs in HITL: the output driver in HIL mode,
`sensors` and `commander` in HIL mode, and one MAVLink instance on a serial device that carries
HIL_SENSOR / HIL_GPS in and HIL_ACTUATOR_CONTROLS out, with commands and offboard setpoints on
the same link. Nothing else publishes sensor data, so the HIL sensors are uORB instance 0.
"""

from __future__ import annotations

from pathlib import Path

from hil.boards.px4.parameters import param_set_lines

HITL_BAUD = 921600
# Above 5000 B/s the mavlink module opens its HIL gate; 800 kB/s leaves room for the telemetry streams.
HITL_DATA_RATE_BPS = 800_000
AIRFRAME = 10016  # none_iris: quad X, PWM_MAIN_FUNC1..4 = Motor1..4, the same airframe as PX4 SITL's default

_SCRIPT = """#!/bin/sh
# Written by hil-bench for one HITL rehearsal: PX4's SYS_HITL=1 start-up on a posix build.
set +e
. px4-alias.sh
PATH="$PATH:${{R}}etc/init.d-posix"
set VEHICLE_TYPE none
set LOGGER_ARGS ""
set LOGGER_BUF 1000

param select parameters.bson
if [ -f parameters.bson ]; then param import; fi
param select-backup parameters_backup.bson

param set SYS_AUTOSTART {airframe}
param set MAV_SYS_ID $((px4_instance+1))
param set SYS_HITL 1
# the device ids under which mavlink_receiver publishes HIL_SENSOR's IMU and magnetometer
param set CAL_ACC0_ID 1310988
param set CAL_GYRO0_ID 1310988
param set CAL_MAG0_ID 197388
param set CAL_MAG0_PRIO 50
param set SENS_BOARD_X_OFF 0.000001
# a desk has no battery, no USB power check and no RC: the same defaults PX4 SITL uses
param set-default BAT1_N_CELLS 4
param set-default CBRK_SUPPLY_CHK 894281
param set-default CBRK_USB_CHK 197848
param set-default COM_CPU_MAX -1
param set-default COM_RC_IN_MODE 1
param set-default MAV_PROTO_VER 2
# log from boot to shutdown, so the flight log covers preflight and the disarm
param set-default SDLOG_MODE 1
param set-default SDLOG_DIRS_MAX 7

for airframe_file in ${{R}}etc/init.d-posix/airframes/{airframe}_*; do
	case "$(basename "$airframe_file")" in *.*) ;; *) . "$airframe_file" ;; esac
done
{param_lines}
dataman start
load_mon start
tone_alarm start
rc_update start
manual_control start
pwm_out_sim start -m hil
sensors start -h
commander start -h
mavlink start -d {device} -b {baud} -r {rate} -m onboard
if param compare -s EKF2_EN 1
then
	ekf2 start &
fi
. ${{R}}etc/init.d/rc.vehicle_setup
navigator start
if param compare -s EKF2_EN 1
then
	set LOGGER_ARGS "-p ekf2_timestamps"
else
	set LOGGER_ARGS "-p vehicle_attitude"
fi
. ${{R}}etc/init.d/rc.logging
mavlink boot_complete
echo "INFO  [hil-bench] HITL start-up complete, HIL link on {device}"
"""


def write_hitl_startup(path: Path, device: str, params: dict[str, float | int] | None = None) -> Path:
    """Write the script for a HIL link on `device`; `params` are set after the airframe's own."""
    lines = param_set_lines(params or {})
    path.write_text(_SCRIPT.format(airframe=AIRFRAME, device=device, baud=HITL_BAUD, rate=HITL_DATA_RATE_BPS,
                                   param_lines=lines))
    return path
