"""The bench's dealings with the machine it runs on: real-time priority and CPU pinning, stop signals, child
processes that die with the bench, their CPU time.

Imports nothing of hil but hil.exit_codes.
"""
