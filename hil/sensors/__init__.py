"""Sensor models: what a Pixhawk's IMU, magnetometer, barometer and GPS would report."""

from hil.sensors.config import BaroConfig, GpsConfig, ImuConfig, MagConfig
from hil.sensors.faults import SensorFault
from hil.sensors.geodesy import Home
from hil.sensors.suite import SensorChoice, SensorsConfig, SensorSuite
from hil.sensors.truth import TrueState

__all__ = ["BaroConfig", "GpsConfig", "Home", "ImuConfig", "MagConfig", "SensorChoice", "SensorFault",
           "SensorSuite", "SensorsConfig", "TrueState"]
