"""PX4's own numbers on MAVLink that the common dialect does not define (PX4 v1.15.4:
src/modules/commander/px4_custom_mode.h, Commander.cpp)."""

from __future__ import annotations

from enum import IntEnum

# custom_mode of HEARTBEAT and DO_SET_MODE: main mode in bits 16-23, sub mode in bits 24-31
PX4_MAIN_MODE_MANUAL, PX4_MAIN_MODE_ALTCTL, PX4_MAIN_MODE_POSCTL, PX4_MAIN_MODE_AUTO = 1, 2, 3, 4
PX4_MAIN_MODE_ACRO, PX4_MAIN_MODE_OFFBOARD, PX4_MAIN_MODE_STABILIZED = 5, 6, 7
PX4_AUTO_SUB_MODE_READY, PX4_AUTO_SUB_MODE_TAKEOFF, PX4_AUTO_SUB_MODE_LOITER = 1, 2, 3
PX4_AUTO_SUB_MODE_MISSION, PX4_AUTO_SUB_MODE_RTL, PX4_AUTO_SUB_MODE_LAND = 4, 5, 6
FORCE_DISARM_MAGIC = 21196  # COMPONENT_ARM_DISARM param2: disarm even in the air


def custom_mode(main_mode: int, sub_mode: int = 0) -> int:
    """HEARTBEAT.custom_mode for a PX4 main mode and sub mode."""
    return main_mode << 16 | sub_mode << 24


class FlightMode(IntEnum):
    """The PX4 modes the emulator flies, valued as HEARTBEAT.custom_mode carries them."""

    MANUAL = custom_mode(PX4_MAIN_MODE_MANUAL)
    POSCTL = custom_mode(PX4_MAIN_MODE_POSCTL)
    AUTO_TAKEOFF = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_TAKEOFF)
    AUTO_LOITER = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_LOITER)
    AUTO_MISSION = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_MISSION)
    AUTO_RTL = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_RTL)
    AUTO_LAND = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_LAND)
    OFFBOARD = custom_mode(PX4_MAIN_MODE_OFFBOARD)

    @property
    def label(self) -> str:
        """As QGroundControl's mode menu and the scenarios spell it: POSCTL, AUTO.MISSION, ..."""
        return self.name.replace("_", ".", 1)

    @property
    def is_auto(self) -> bool:
        return self >> 16 & 0xFF == PX4_MAIN_MODE_AUTO

    @property
    def ui_name(self) -> str:
        """PX4's own name of the mode (commander's nav_state_names), as its STATUSTEXT says it."""
        return _UI_NAMES[self]


_UI_NAMES = {FlightMode.MANUAL: "Manual", FlightMode.POSCTL: "Position", FlightMode.AUTO_TAKEOFF: "Takeoff",
             FlightMode.AUTO_LOITER: "Hold", FlightMode.AUTO_MISSION: "Mission", FlightMode.AUTO_RTL: "Return",
             FlightMode.AUTO_LAND: "Land", FlightMode.OFFBOARD: "Offboard"}
_MAIN_NAMES = {PX4_MAIN_MODE_MANUAL: "MANUAL", PX4_MAIN_MODE_ALTCTL: "ALTCTL", PX4_MAIN_MODE_POSCTL: "POSCTL",
               PX4_MAIN_MODE_AUTO: "AUTO", PX4_MAIN_MODE_ACRO: "ACRO", PX4_MAIN_MODE_OFFBOARD: "OFFBOARD",
               PX4_MAIN_MODE_STABILIZED: "STABILIZED"}
_AUTO_SUB_NAMES = {PX4_AUTO_SUB_MODE_READY: "READY", PX4_AUTO_SUB_MODE_TAKEOFF: "TAKEOFF",
                   PX4_AUTO_SUB_MODE_LOITER: "LOITER", PX4_AUTO_SUB_MODE_MISSION: "MISSION",
                   PX4_AUTO_SUB_MODE_RTL: "RTL", PX4_AUTO_SUB_MODE_LAND: "LAND"}


def mode_name(mode: int) -> str:
    """A HEARTBEAT.custom_mode of PX4 as text (POSCTL, AUTO.MISSION, ...); unknown numbers in hexadecimal."""
    main, sub = mode >> 16 & 0xFF, mode >> 24 & 0xFF
    name = _MAIN_NAMES.get(main)
    if name is None:
        return f"0x{mode:08x}"
    if main == PX4_MAIN_MODE_AUTO and sub:
        return f"AUTO.{_AUTO_SUB_NAMES.get(sub, str(sub))}"
    return name


# the name `mode_name` gives each known mode, as a scenario's expectations may name them (AUTO has a sub mode)
PX4_MODE_NAMES = tuple([mode_name(custom_mode(main)) for main in sorted(_MAIN_NAMES) if main != PX4_MAIN_MODE_AUTO]
                       + [mode_name(custom_mode(PX4_MAIN_MODE_AUTO, sub)) for sub in sorted(_AUTO_SUB_NAMES)])
