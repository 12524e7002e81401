"""The run's outputs, each a sink of the loop (`hil.loop.sink.Sink`): the run directory and its MCAP recording,
Zenoh telemetry, the live Foxglove view; and what reads them back (recovery of a cut recording).

May import hil.loop (frames, the sink contract), hil.channels, hil.scenario, hil.host and firmware_interface.
"""
