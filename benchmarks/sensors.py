"""µs per bench step for the full sensor suite (IMU, mag, baro, GPS) at 250 Hz, per profile set."""

from __future__ import annotations

import time

import numpy as np
from run_timing import benchmark_parser

from hil.sensors import Home, SensorChoice, SensorsConfig, SensorSuite, TrueState

STEPS, QUICK_STEPS = 50_000, 250
PROFILE_SETS = {
    "ideal": SensorsConfig(**{k: SensorChoice(profile="ideal") for k in ("imu", "mag", "baro", "gps")}),
    "px4_sitl": SensorsConfig(),
    "paper parts (mpu6050, m8n, ms5611)": SensorsConfig(imu=SensorChoice(profile="mpu6050"),
                                                        gps=SensorChoice(profile="m8n"),
                                                        baro=SensorChoice(profile="ms5611")),
}


def bench(config: SensorsConfig, steps: int) -> float:
    suite = SensorSuite(config, Home(), 250.0, np.random.default_rng(0))
    pos, vel = np.array([1.0, 2.0, -10.0]), np.array([0.5, 0.0, 0.0])
    q, rates, force = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, -9.80665])
    start = time.perf_counter()
    for k in range(steps):
        suite.step(TrueState(k * 4000, pos, vel, q, rates, force))
    return (time.perf_counter() - start) / steps * 1e6


def main() -> None:
    steps = QUICK_STEPS if benchmark_parser(__doc__).parse_args().quick else STEPS
    print(f"sensor suite, 250 Hz bench, {steps} steps (includes building the TrueState)")
    for name, config in PROFILE_SETS.items():
        print(f"  {name:36s}: {bench(config, steps):6.2f} us/step")


if __name__ == "__main__":
    main()
