"""The simulator's versions: which instrument parameters each one's nominal bench has, and what
its protocol does between trials.

``simulate()`` and ``InstrumentParams()`` are the default version, :data:`DEFAULT_VERSION`
(``psmforce.sim.dataset.SIM_VERSION``, the one written into every dataset's ``metadata.json``
and the one every committed result was produced on). A later version is a set of parameter
changes on top of it, :data:`CHANGES`, plus the bench's between-trial settings
(:class:`Version`: the re-mount before each trial); :func:`instrument` builds its nominal
``InstrumentParams``, :func:`version` the whole definition, which ``simulate(version=...)``
and ``psmforce.experiments.reproduce.reproduce(sim_version=...)`` take. A version becomes the
default only when the comparisons are rerun on it (issue 45): until then the default bench's
output is bit for bit what it was (``tests/sim/test_sim_versions.py``).

2.2 (not the default yet): the cable law calibrated against every folder of a real EndoWrist's
transmission recordings (MRD Lab; docs/simulator.md section 12b): a load-independent Coulomb
friction of the cable path proximal of the HEX10 section (``cable_coulomb_n``, the friction the
real tool shows at zero load, which 2.1 lacks), the share of it the stretching cable run carries
(``cable_coulomb_stretch_share``), and the cable stiffness, capstan wraps and their pose gains
refitted with it. Fitted by ``python studies/sim_calibration.py --cable-law --fit`` (least
squares on the log ratios sim / real of the checked figures over the seven folders).

2.3 (not the default yet): 2.2's cable law (the wrist's hysteresis and lost motion, grounded on
the MRD Lab recordings) plus the effects by which the robot's internal forces depend on the
motion's history and on the trial, docs/simulator.md section 12c: the roll drive's lost motion
(``roll_backlash_rad``, :mod:`psmforce.sim.shaft`), the lag of the HEX10's readout
(``hex10_readout_lag_s``, :func:`psmforce.sim.sensors.readout_lag`), its thermal settling after
each zeroing (``hex10_thermal_drift_n``, ``hex10_thermal_time_s``) and a re-mount of the
instrument before every trial, followed by the HEX10's zeroing (``remount_spread``,
:meth:`psmforce.sim.mounting.Remount.zeroed`). Sizes assumed, then calibrated against the
paper's Table III on the FCN, the LSTM and MultiRocket-Hydra by
``studies/bench_paper_calibration.py`` (its ``CANDIDATES``: every setting tried).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from psmforce.sim.params import InstrumentParams

DEFAULT_VERSION = "2.1"
"""The version ``InstrumentParams()`` is (equal to ``psmforce.sim.dataset.SIM_VERSION``)."""

_V22 = {
    "cable_coulomb_n": 23.0,
    "cable_coulomb_stretch_share": 0.234375,
    "cable_stiffness_n_per_m": 2.425e5,
    "capstan_mu_wrap_distal": 0.14625,
    "capstan_mu_wrap_proximal": 0.1075,
    "twist_friction_gain_per_rad": 0.0,
    "capstan_wrap_pitch_gain": 0.675,
}

CHANGES: dict[str, dict[str, float]] = {
    "2.1": {},
    "2.2": dict(_V22),
    "2.3": {**_V22,
            "roll_backlash_rad": 0.09,
            "hex10_readout_lag_s": 0.1,
            "hex10_thermal_drift_n": 0.1,
            "hex10_thermal_time_s": 60.0},
}
"""Per version, the ``InstrumentParams`` fields that differ from the default version's."""

REMOUNT_SPREAD: dict[str, float] = {"2.1": 0.0, "2.2": 0.0, "2.3": 2.0}
"""Per version, the spread (times :data:`psmforce.sim.mounting.RANGES`) of the re-mount drawn
before each trial; 0: the instrument stays mounted for the whole bench."""

VERSIONS = tuple(CHANGES)


@dataclass(frozen=True)
class Version:
    """One simulator version's definition: its name, the ``InstrumentParams`` fields that differ
    from the default version's, and the re-mount spread between trials. A candidate under
    calibration is a ``Version`` with a name of its own (not in :data:`VERSIONS`)."""

    name: str
    changes: dict = field(default_factory=dict)
    remount_spread: float = 0.0

    def __post_init__(self):
        unknown = set(self.changes) - {f.name for f in dataclasses.fields(InstrumentParams)}
        if unknown:
            raise ValueError(f"version {self.name!r}: unknown InstrumentParams fields "
                             f"{sorted(unknown)}")
        spread = self.remount_spread
        if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not (
                math.isfinite(spread) and spread >= 0):
            raise ValueError(f"version {self.name!r}: remount_spread must be a finite number "
                             f">= 0, got {spread!r}")

    def instrument(self) -> InstrumentParams:
        """The nominal instrument of this version."""
        return dataclasses.replace(InstrumentParams(), **self.changes)

    def to_dict(self) -> dict:
        return {"name": self.name, "changes": dict(sorted(self.changes.items())),
                "remount_spread": float(self.remount_spread)}

    @classmethod
    def from_dict(cls, d: dict) -> "Version":
        return cls(d["name"], dict(d.get("changes", {})), float(d.get("remount_spread", 0.0)))


def version(name: str | Version | None = None) -> Version:
    """The definition of simulator version ``name`` (None: the default; a :class:`Version`
    passes through)."""
    if isinstance(name, Version):
        return name
    name = DEFAULT_VERSION if name is None else name
    if name not in CHANGES:
        raise ValueError(f"unknown simulator version {name!r}; known: {', '.join(VERSIONS)}")
    return Version(name, dict(CHANGES[name]), REMOUNT_SPREAD[name])


def instrument(name: str | Version = DEFAULT_VERSION) -> InstrumentParams:
    """The nominal instrument of simulator version ``name``."""
    return version(name).instrument()
