"""The HIL bench: scenarios, the loop, sensors, telemetry, recording and metrics."""
