"""Simulated bench: dVRK PSM + modified EndoWrist Cadiere forceps with a HEX10 in the shaft, an ATI
Nano17 under the fixtures, and the seed paper's protocols. Physics and calibration:
docs/simulator.md."""

from psmforce.sim.ati_free import simulate_ati_free  # a lab's recordings without an ATI
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.dataset import SimulationConfigError, simulate
from psmforce.sim.mounting import Remount  # Remount.draw(seed).apply(params): a re-mounted tool
from psmforce.sim.params import Effects, InstrumentParams
from psmforce.sim.port import PORT_NAMES, PORTS, Port
from psmforce.sim import versions  # versions.instrument("2.2"): a later version's nominal tool

__all__ = ["simulate", "InstrumentParams", "Effects", "SimulationConfigError", "run_trajectory", "Contact",
           "Port", "PORTS", "PORT_NAMES", "versions", "Remount", "simulate_ati_free"]
