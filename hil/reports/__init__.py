"""Reading a run back and showing it: the run directory's data (`rundata`), the one-page report.html and its
figures, the PNG figures of `hil report` drawn as the paper draws them.

May import hil.outputs (the recording's channels), hil.channels, hil.judge, hil.scenario, hil.exit_codes and
firmware_interface; never the loop's running parts.
"""
