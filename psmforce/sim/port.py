"""The port: the instrument shaft passes through a cannula at the remote centre of motion.

Frames and signs: base = RCM frame (m); ``d`` the unit shaft direction towards the tip; forces
are those the port applies ON the tool shaft (like the contact forces), acting at the point of
the shaft closest to the port's pivot, which lies proximal of the HEX10: the joints feel them,
the HEX10 does not. Two parts (docs/simulator.md, section 8b, with sources):

* seal friction along the shaft (and about it, on roll): Coulomb + viscous + Stribeck/stiction,
  rippling with the insertion depth, higher on retraction, growing with the lateral load on the
  seal (friction coefficient); it joins the insertion and roll friction laws of
  :mod:`psmforce.sim.drive` (one stick-slip law per joint);
* lateral force: the port's pivot ``p`` sits ``misalignment_m`` from the RCM (and moves with
  breathing); the wall pushes the shaft back towards it, ``F = k (I - d d^T)(p - 0)``, applied at
  ``s = (p . d) d``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

PORT_NAMES = ("none", "cannula", "abdominal-wall")


@dataclass(frozen=True)
class Port:
    """One port condition. Levels in N (axial), N/m, m, Hz."""

    name: str
    seal_coulomb_n: float
    """Kinetic seal friction along the shaft."""
    seal_static_n: float
    """Breakaway seal friction (the fluctuation at starts and reversals)."""
    seal_viscous_n_s_per_m: float
    seal_stribeck_velocity_mps: float
    seal_smoothing_mps: float
    """Speed over which the seal friction changes sign at a reversal (a rubber lip: sharp)."""
    retraction_excess: float
    """Relative extra friction while the shaft is pulled out (v < 0)."""
    depth_ripple: float
    """Relative ripple of the seal friction with insertion depth."""
    depth_wavelength_m: float
    lateral_friction_coefficient: float
    """Extra axial friction per N of lateral load on the seal."""
    lateral_stiffness_n_per_m: float
    misalignment_m: tuple[float, float, float]
    """Port pivot minus RCM (base frame, m)."""
    breathing_amplitude_m: tuple[float, float, float]
    breathing_hz: float
    shaft_radius_m: float = 0.004
    """8 mm shaft: the seal's friction moment about the shaft on roll = friction x radius."""

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(self).items()}


PORTS = {
    "cannula": Port("cannula", seal_coulomb_n=0.5, seal_static_n=0.9, seal_viscous_n_s_per_m=2.0,
                    seal_stribeck_velocity_mps=0.005, seal_smoothing_mps=0.001,
                    retraction_excess=0.2, depth_ripple=0.2,
                    depth_wavelength_m=0.03, lateral_friction_coefficient=0.3,
                    lateral_stiffness_n_per_m=2000.0, misalignment_m=(0.0, 0.0, -0.002),
                    breathing_amplitude_m=(0.0, 0.0, 0.0), breathing_hz=0.0),
    "abdominal-wall": Port("abdominal-wall", seal_coulomb_n=1.0, seal_static_n=1.8,
                           seal_viscous_n_s_per_m=4.0, seal_stribeck_velocity_mps=0.005,
                           seal_smoothing_mps=0.001,
                           retraction_excess=0.3, depth_ripple=0.3, depth_wavelength_m=0.02,
                           lateral_friction_coefficient=0.3, lateral_stiffness_n_per_m=500.0,
                           misalignment_m=(0.003, 0.0, -0.010),
                           breathing_amplitude_m=(0.002, 0.0, 0.003), breathing_hz=0.25),
}
"""Named conditions (``none`` is no port: the paper's benchtop)."""


def port_by_name(name: str) -> Port | None:
    if name not in PORT_NAMES:
        raise ValueError(f"port: unknown {name!r}, expected one of {PORT_NAMES}")
    return PORTS.get(name)


def lateral_force(port: Port, d_shaft: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lateral force ON the shaft (N, 3) and where it acts (N, 3), base frame: the pivot ``p(t)``
    (misalignment + breathing) pulls the shaft towards it with the wall's stiffness."""
    p = (np.asarray(port.misalignment_m)[None, :]
         + np.asarray(port.breathing_amplitude_m)[None, :] * np.sin(2 * np.pi * port.breathing_hz * t)[:, None])
    along = np.einsum("ij,ij->i", p, d_shaft)
    at = along[:, None] * d_shaft
    return port.lateral_stiffness_n_per_m * (p - at), at


def seal_levels(port: Port, insertion: np.ndarray, velocity: np.ndarray,
                lateral_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic and breakaway seal friction levels (N,) along the shaft (N)."""
    scale = ((1.0 + port.depth_ripple * np.sin(2 * np.pi * insertion / port.depth_wavelength_m))
             * (1.0 + port.retraction_excess * (velocity < 0)))
    extra = port.lateral_friction_coefficient * lateral_n
    return port.seal_coulomb_n * scale + extra, port.seal_static_n * scale + extra
