"""Who flies the vehicle: each pilot decides, step by step, what the board is asked and what it flies (the
contract is `hil.loop.pilot.Pilot`). One module per pilot kind, registered in `registry.py`.

May import hil.loop, hil.judge, hil.boards, hil.scenario, hil.sensors, plant_fmu and firmware_interface.
"""
