"""Board kinds: how the bench attaches to what flies (the emulator, PX4 SITL, PX4's HITL path on a pty, a board
on a port) and each kind's policy. One module per kind, registered in `registry.py`.

May import hil.host, hil.scenario, hil.sensors and firmware_interface; never the loop, the pilots or the outputs.
"""
