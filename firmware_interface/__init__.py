"""MAVLink to and from a flight controller board, and the software board emulator."""
