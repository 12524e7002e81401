"""Judging a flight: its tracking and estimate figures from each step's frame (a sink of the loop), the checks that
end a flight gone wrong (left the ground, hit it, tumbled), and the scenario's expectations against the figures.

May import hil.loop (frames), hil.scenario, hil.exit_codes, plant_fmu and firmware_interface.
"""
