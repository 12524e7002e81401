"""One run, from a scenario to its run directory, exit code and summary: the outputs opened, the board attached,
the world and the pilot built, the loop flown, the flight judged, everything closed whatever ended it.

May import the parts it wires (hil.boards, hil.loop, hil.pilots, hil.judge, hil.outputs) and what they import.
"""
