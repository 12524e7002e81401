"""The quadrotor plant: an FMI 2.0 co-simulation FMU built from C, and a thin fmpy wrapper."""

from plant_fmu.build import FmuBuildError, build_fmu, ensure_fmu
from plant_fmu.plant import Plant, PlantError
from plant_fmu.state import PlantState

__all__ = ["FmuBuildError", "Plant", "PlantError", "PlantState", "build_fmu", "ensure_fmu"]
