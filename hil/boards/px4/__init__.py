"""Real PX4 as the bench's board: find a build, claim an instance, start and stop PX4 for one run."""

from hil.boards.px4.build import Px4Build, Px4SetupError
from hil.boards.px4.process import Px4Process, claim_instance

__all__ = ["Px4Build", "Px4Process", "Px4SetupError", "claim_instance"]
