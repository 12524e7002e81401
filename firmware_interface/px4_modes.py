"""PX4's own numbers on MAVLink that the common dialect does not define (PX4 v1.15.4:
src/modules/commander/px4_custom_mode.h, Commander.cpp)."""

# custom_mode of HEARTBEAT and DO_SET_MODE: main mode in bits 16-23, sub mode in bits 24-31
PX4_MAIN_MODE_POSCTL, PX4_MAIN_MODE_AUTO, PX4_MAIN_MODE_OFFBOARD = 3, 4, 6
PX4_AUTO_SUB_MODE_LAND = 6
FORCE_DISARM_MAGIC = 21196  # COMPONENT_ARM_DISARM param2: disarm even in the air


def custom_mode(main_mode: int, sub_mode: int = 0) -> int:
    """HEARTBEAT.custom_mode for a PX4 main mode and sub mode."""
    return main_mode << 16 | sub_mode << 24
