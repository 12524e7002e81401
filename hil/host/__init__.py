"""The bench's dealings with the machine it runs on: real-time priority and CPU pinning, stop signals, child
processes that die with the bench, their CPU time, work on a thread beside the caller's.

Imports nothing of hil but hil.exit_codes.
"""
