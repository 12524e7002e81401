"""The plant: a contract every plant FMU is driven through (mapped by name, unit and frame), our own
multirotor FMU built from C, and a thin fmpy wrapper that steps any of them."""

from plant_fmu.build import FmuBuildError, build_fmu, ensure_fmu
from plant_fmu.plant import Plant, PlantError
from plant_fmu.state import BatteryState, PlantState

__all__ = ["BatteryState", "FmuBuildError", "Plant", "PlantError", "PlantState", "build_fmu", "ensure_fmu"]
