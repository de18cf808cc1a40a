"""The simulator's versions: which instrument parameters each one's nominal bench has.

``simulate()`` and ``InstrumentParams()`` are the default version, :data:`DEFAULT_VERSION`
(``psmforce.sim.dataset.SIM_VERSION``, the one written into every dataset's ``metadata.json``
and the one every committed result was produced on). A later version is a set of parameter
changes on top of it, :data:`CHANGES`; :func:`instrument` builds its nominal
``InstrumentParams`` (pass it as ``simulate(instrument=...)``). A version becomes the default
only when the comparisons are rerun on it (issue 45): until then the default bench's output is
bit for bit what it was (``tests/sim/test_sim_versions.py``).

2.2 (not the default yet): the cable law calibrated against every folder of a real EndoWrist's
transmission recordings (MRD Lab; docs/simulator.md section 12b): a load-independent Coulomb
friction of the cable path proximal of the HEX10 section (``cable_coulomb_n``, the friction the
real tool shows at zero load, which 2.1 lacks), the share of it the stretching cable run carries
(``cable_coulomb_stretch_share``), and the cable stiffness, capstan wraps and their pose gains
refitted with it. Fitted by ``python studies/sim_calibration.py --cable-law --fit`` (least
squares on the log ratios sim / real of the checked figures over the seven folders).
"""

from __future__ import annotations

import dataclasses

from psmforce.sim.params import InstrumentParams

DEFAULT_VERSION = "2.1"
"""The version ``InstrumentParams()`` is (equal to ``psmforce.sim.dataset.SIM_VERSION``)."""

CHANGES: dict[str, dict[str, float]] = {
    "2.1": {},
    "2.2": {
        "cable_coulomb_n": 23.0,
        "cable_coulomb_stretch_share": 0.234375,
        "cable_stiffness_n_per_m": 2.425e5,
        "capstan_mu_wrap_distal": 0.14625,
        "capstan_mu_wrap_proximal": 0.1075,
        "twist_friction_gain_per_rad": 0.0,
        "capstan_wrap_pitch_gain": 0.675,
    },
}
"""Per version, the ``InstrumentParams`` fields that differ from the default version's."""

VERSIONS = tuple(CHANGES)


def instrument(version: str = DEFAULT_VERSION) -> InstrumentParams:
    """The nominal instrument of simulator ``version``."""
    if version not in CHANGES:
        raise ValueError(f"unknown simulator version {version!r}; known: {', '.join(VERSIONS)}")
    return dataclasses.replace(InstrumentParams(), **CHANGES[version])
