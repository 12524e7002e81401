"""Which serial ports look like a flight controller running PX4, by their USB identity."""

from __future__ import annotations

# USB vendor ids that PX4 boards enumerate with (PX4's own boards' USB descriptors): the PX4/3D Robotics
# id of the FMU family, CubePilot (Hex) and Holybro.
PX4_USB_VENDORS = {0x26AC: "PX4 FMU", 0x2DAE: "CubePilot", 0x3162: "Holybro"}


def pixhawk_maker(vid: int | None, description: str | None) -> str | None:
    """The maker of a PX4 board behind a USB port, or None; the product string counts when the id is unknown."""
    if vid in PX4_USB_VENDORS:
        return PX4_USB_VENDORS[vid]
    text = (description or "").lower()
    return "PX4" if "px4" in text or "pixhawk" in text else None
