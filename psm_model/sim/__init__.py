"""Simulated bench: dVRK PSM + modified EndoWrist Cadiere forceps with a HEX10 in the shaft, an ATI
Nano17 under the fixtures, and the seed paper's protocols. Physics and calibration:
docs/simulator.md."""

from .bench import Contact, run_trajectory
from .dataset import SimulationConfigError, simulate
from .params import Effects, InstrumentParams

__all__ = ["simulate", "InstrumentParams", "Effects", "SimulationConfigError", "run_trajectory", "Contact"]
