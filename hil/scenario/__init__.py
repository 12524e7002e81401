"""Scenarios: the schema and loader, and the time-varying inputs of a run."""
