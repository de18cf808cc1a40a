"""Re-mounting the instrument: what removing it from the PSM and re-attaching it changes.

The paper resets before every trial: "removing the instrument, re-attaching it to the PSM, and
zeroing the HEX10" (section "Experimental procedure"). :class:`Remount` is one such reset applied
to an :class:`~psmforce.sim.params.InstrumentParams`: it changes the parameters a re-mount can
change and nothing else (the cables, pulleys, friction and the cable law stay the instrument's):

* **pretension** (``pretension_total_n``): the discs are re-seated on the sterile adapter
  without re-tensioning the cables, so the preload the HEX10 sees moves a little;
* **HEX10 offset** (``hex10_residual_bias_n``): the sensor is zeroed again, which leaves another
  residual force offset. The bench's tare convention is kept (docs/simulator.md section 7: the
  zero is that of the unloaded sensor, so the pretension stays in the reading, about -6 N at
  rest as in the paper);
* **misalignment** (``hex10_mount_rotation_rad``): the frame the HEX10 measures in turns about
  the shaft and tilts a little against the frame the bench computes the section wrench in
  (:func:`psmforce.sim.sensors.hex10_reading`). The whole section wrench is turned, cable
  compression included, so a tilt leaks part of the axial compression into the lateral
  channels: the harsh reading of a re-seat (the cables' resultant settling off the sensor
  axis); a tilt of the kinematic chain alone would turn only the tip load and the distal weight.

The constant effort offsets a re-mount leaves on the instrument joints are already drawn per
recording by the bench (effect ``remount_offsets``, docs/simulator.md section 8).

:data:`RANGES` states each change's range and its source: a paper figure where one exists,
"assumed" where none does. :meth:`Remount.draw` draws a change inside those ranges (seeded,
deterministic); :meth:`Remount.apply` returns the re-mounted instrument. ``Remount()`` changes
nothing: the re-mounted bench is the same bench, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from psmforce.sim.params import InstrumentParams
from psmforce.sim.sensors import mount_rotation

RANGES = {
    "pretension_change_n": {
        "bound": 1.0, "unit": "N", "law": "uniform in [-bound, bound]",
        "source": "assumed, bounded by the paper: the tool was retensioned to a ~8 N axial "
                  "preload target and 6 N was observed on the HEX10; a re-mount re-seats the "
                  "discs without re-tensioning, taken as half that 2 N gap either way"},
    "hex10_offset_change_n": {
        "bound": 0.1, "unit": "N", "law": "uniform in [-bound, bound] per force axis",
        "source": "assumed: the paper zeroes the HEX10 at each reset but gives no residual; "
                  "about twice the distal weight (5.5 g, 0.054 N) a zero taken off the upright "
                  "pose leaves, the order of the paper's free-space noise envelope "
                  "(0.057 / 0.072 N RMSE)"},
    "rotation_about_shaft_rad": {
        "bound": 0.02, "unit": "rad", "law": "uniform in [-bound, bound]",
        "source": "assumed (about 1.1 degrees; no published figure for the re-seat of an "
                  "EndoWrist on the sterile adapter)"},
    "tilt_rad": {
        "bound": 0.005, "unit": "rad",
        "law": "magnitude uniform in [0, bound], direction uniform about the shaft",
        "source": "assumed (about 0.3 degrees; no published figure)"},
}
"""Each change a re-mount makes: its bound, unit, distribution (at ``spread`` 1) and source."""


@dataclass(frozen=True)
class Remount:
    """One removal and re-attachment of the instrument, as changes to its parameters.

    ``rotation_change_rad``: angles (about x, y, z of the HEX10 frame, z the shaft) added to
    ``InstrumentParams.hex10_mount_rotation_rad``; x and y are the tilt, z the turn about the
    shaft.
    """

    pretension_change_n: float = 0.0
    hex10_offset_change_n: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation_change_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        values = [self.pretension_change_n, *self.hex10_offset_change_n, *self.rotation_change_rad]
        if (len(self.hex10_offset_change_n) != 3 or len(self.rotation_change_rad) != 3
                or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)):
            raise ValueError(f"Remount: finite numbers expected (1 + 3 + 3), got {self!r}")

    @classmethod
    def draw(cls, seed: int, spread: float = 1.0) -> "Remount":
        """A re-mount drawn inside :data:`RANGES` (bounds times ``spread``), deterministic in
        ``seed``."""
        return cls._drawn(np.random.default_rng([int(seed), 44]), spread)

    @classmethod
    def draw_for_trial(cls, bench_seed: int, trial: int, spread: float = 1.0) -> "Remount":
        """The re-mount before trial number ``trial`` of the bench simulated with ``bench_seed``
        (simulator 2.3 re-mounts before every trial, :mod:`psmforce.sim.versions`): drawn as
        :meth:`draw`, from a stream of its own, deterministic in (``bench_seed``, ``trial``)."""
        return cls._drawn(np.random.default_rng([int(bench_seed), 46, int(trial)]), spread)

    @classmethod
    def _drawn(cls, rng: np.random.Generator, spread: float) -> "Remount":
        if not (isinstance(spread, (int, float)) and 0.0 <= spread and math.isfinite(spread)):
            raise ValueError(f"spread must be a finite number >= 0, got {spread!r}")
        b = {k: spread * v["bound"] for k, v in RANGES.items()}
        pretension = rng.uniform(-1.0, 1.0) * b["pretension_change_n"]
        offset = rng.uniform(-1.0, 1.0, 3) * b["hex10_offset_change_n"]
        about_shaft = rng.uniform(-1.0, 1.0) * b["rotation_about_shaft_rad"]
        tilt, direction = rng.uniform(0.0, 1.0) * b["tilt_rad"], rng.uniform(0.0, 2 * np.pi)
        return cls(float(pretension), tuple(float(x) for x in offset),
                   (float(tilt * np.cos(direction)), float(tilt * np.sin(direction)),
                    float(about_shaft)))

    @property
    def tilt_rad(self) -> float:
        """Magnitude of the tilt change (rad)."""
        return float(math.hypot(self.rotation_change_rad[0], self.rotation_change_rad[1]))

    def within_ranges(self, spread: float = 1.0) -> bool:
        """Whether every change lies inside :data:`RANGES` (bounds times ``spread``)."""
        b = {k: spread * v["bound"] for k, v in RANGES.items()}
        return (abs(self.pretension_change_n) <= b["pretension_change_n"]
                and max(map(abs, self.hex10_offset_change_n)) <= b["hex10_offset_change_n"]
                and abs(self.rotation_change_rad[2]) <= b["rotation_about_shaft_rad"]
                and self.tilt_rad <= b["tilt_rad"] * (1 + 1e-12))

    def apply(self, params: InstrumentParams) -> InstrumentParams:
        """The instrument after this re-mount. Raises ``ValueError`` if the pretension would
        not stay positive."""
        pretension = params.pretension_total_n + self.pretension_change_n
        if not pretension > 0.0:
            raise ValueError(f"re-mount leaves a pretension of {pretension:g} N (must be > 0)")
        return dataclasses.replace(
            params, pretension_total_n=pretension,
            hex10_residual_bias_n=tuple(float(b + d) for b, d in
                                        zip(params.hex10_residual_bias_n, self.hex10_offset_change_n)),
            hex10_mount_rotation_rad=tuple(float(r + d) for r, d in
                                           zip(params.hex10_mount_rotation_rad, self.rotation_change_rad)))

    def zeroed(self, params: InstrumentParams) -> InstrumentParams:
        """The instrument after this re-mount and the HEX10's zeroing that follows it (the
        paper's reset: "removing the instrument, re-attaching it to the PSM, and zeroing the
        HEX10"): :meth:`apply`, with the change the re-mount makes to the sensor's force reading
        at rest taken out of ``hex10_residual_bias_n``. At rest (straight wrist, roll 0, no load)
        the section force is the cables' ``(0, 0, -T)``, ``T = pretension_total_n``, read as
        ``X R^T (0, 0, -T)`` (``R``: the mount rotation, ``X``: the force block of the
        cross-talk), so the zero removes ``X (R'^T (0, 0, -T') - R^T (0, 0, -T))`` with the
        re-mounted ``T'``, ``R'``. What stays: the zero's own residual (``hex10_offset_change_n``)
        and how the changes act under load and away from the rest pose (a tilt leaks the
        compression's change from rest into the lateral channels; a turn about the shaft turns
        the lateral forces). Distal gravity is the same before and after, so it is not part of
        the change."""
        after = self.apply(params)
        x = np.asarray(params.hex10_crosstalk, dtype=float)[:3, :3]

        def rest(p: InstrumentParams) -> np.ndarray:
            r = mount_rotation(p.hex10_mount_rotation_rad)
            return x @ (r.T @ np.array([0.0, 0.0, -p.pretension_total_n]))

        change = rest(after) - rest(params)
        return dataclasses.replace(after, hex10_residual_bias_n=tuple(
            float(b - c) for b, c in zip(after.hex10_residual_bias_n, change)))

    def to_dict(self) -> dict:
        return {"pretension_change_n": self.pretension_change_n,
                "hex10_offset_change_n": list(self.hex10_offset_change_n),
                "rotation_change_rad": list(self.rotation_change_rad),
                "tilt_rad": self.tilt_rad}
