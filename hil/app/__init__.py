"""The command line (`hil`) and what only its commands use: progress lines, the live views of a run on Zenoh, the
Foxglove bridge, controller comparisons.

May import every other part of hil.
"""
