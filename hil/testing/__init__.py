"""Scenarios as pytest test cases: the plugin pytest loads through the `pytest11` entry point (`plugin.py`), the items
it collects from scenario and sweep files (`collect.py`), one flight in this process (`flight.py`), a flown run as
objects and its verdict as pytest reports it (`results.py`), the fixtures for a user's own tests (`fixtures.py`).

A front end beside hil.app, not inside it: pytest imports it into a user's test process, where it must cost nothing
until asked (--hil, `hil = true` in the ini file, or a fixture), so every module here imports the bench inside its
functions. May import what hil.app may, except hil.app itself; nothing imports it.
"""
