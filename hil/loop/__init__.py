"""The step loop and the contracts of the parts passed into it: a pilot (who decides what the board is asked and
what it flies), sinks (who take each step's frame and the run's events), and the board handle.

May import hil.boards, hil.host, hil.scenario, hil.sensors, plant_fmu and firmware_interface; never the pilots,
the judge's metrics or the outputs, which are passed in.
"""
