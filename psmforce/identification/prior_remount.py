"""Recalibrating the internal-force prior after the instrument was re-mounted.

Removing the instrument from the PSM and re-attaching it (the paper's reset before every trial,
which also zeroes the HEX10) changes a few things about the tool and nothing about its design,
as the cable transmission's per-session parameters do (:mod:`.transmission.model`,
``PER_SESSION``). The prior's parameters split the same way:

* **per mount** (:data:`PER_MOUNT`): the cable pretension (the discs are re-seated), the six
  HEX10 offsets (the sensor is zeroed again), and three small angles (:data:`MOUNT_ANGLES`) of
  the frame the HEX10 measures in against the frame the prior's law is written in (a turn about
  the shaft and a tilt). The angles are not parameters of the law itself: a
  :class:`MountedPrior` turns the law's wrench (without its offsets) by them, then adds the
  offsets;
* **shared** (every other parameter of :data:`~psmforce.identification.prior_law.NAMES`):
  pulley radii, twist gain, pair asymmetries, direction-dependent tension, path term, distal
  mass and its lever, cable radius. They are the instrument's and are kept as fitted.

:func:`recalibrate` re-estimates only the per-mount values from a short free-space recording of
the new mount (about two minutes of wrist motion; no external force), every shared parameter
held, by bounded least squares over the six channels, each scaled by its spread in the data as
the full fit does. Free space pins the offsets directly, the pretension through the roll twist
(``T_tot g_twist roll^2``, with the twist gain held) and the tilt through the axial force's
variation, which a tilt leaks into the lateral channels; the turn about the shaft only through
the distal weight's lateral part and the pair differentials' moments, so its standard error is
the largest (``info["standard_errors"]``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import (InternalForcePrior, _check_arrays, _check_reading,
                                           arrays_from_frame, internal_wrench_target)
from psmforce.identification.prior_law import (MIN_SAMPLES, NAMES, PARAMETERS, SENSOR_CROSSTALK,
                                                _model, sensor_crosstalk)
from psmforce.io.recording import TARGETS

BIASES = ("bias_fx", "bias_fy", "bias_fz", "bias_tx", "bias_ty", "bias_tz")
PER_MOUNT = ("pretension_total",) + BIASES
"""Law parameters a re-mount changes (re-seated discs: the pretension; re-zeroed sensor: the
offsets); every other name of :data:`NAMES` is shared by every mount of the instrument."""
FORCE_PER_MOUNT = ("pretension_total", "bias_fx", "bias_fy", "bias_fz")
"""The per-mount set to re-estimate on the excitation's clenches (docs/ati_free.md section 3): the
pretension and the force offsets; the moment offsets held, since the law's moment terms misread
the clench loads and free offsets absorb that misfit."""
MOUNT_ANGLES = ("mount_about_x", "mount_about_y", "mount_about_z")
"""The mount's misalignment (rad): the HEX10 measures in ``R = Rz(c) Ry(b) Rx(a)`` of the law's
frame, z the shaft; x and y are the tilt."""
TILT = MOUNT_ANGLES[:2]
"""The angles :func:`recalibrate` re-estimates by default. The turn about the shaft is held: in
free space it is seen only through the distal weight's lateral part (0.054 N) and the pair
differentials' moments, about a millinewton per 0.02 rad, below the sensor's noise; left free
it runs to its bound on what the law misses in the lateral moments."""
DRIFT_KNOT_S = 20.0
"""Knot spacing (s) of the force channels' drift, fitted as a nuisance during a recalibration
(:func:`drift_basis`): a random-walk drift over two minutes correlates with the slow part of the
axial variation that identifies the tilt."""
MAX_MOUNT_ANGLE_RAD = 0.05
"""Bound of each fitted angle (rad, about 3 degrees): a re-seat, not a rebuild."""
FREE_SPACE_FORCE_N = 0.5
"""A sample whose known external force (``ati_f*``) exceeds this is not free space."""
MAX_LOADED_FRACTION = 0.01
"""A recalibration recording with more samples above :data:`FREE_SPACE_FORCE_N` is refused."""


def mount_rotation(angles_rad) -> np.ndarray:
    """(3, 3) ``Rz(c) Ry(b) Rx(a)`` for (a, b, c) rad about x, y, z (the same convention the
    simulated bench states for its HEX10; written here so identification never imports it)."""
    a, b, c = (float(x) for x in angles_rad)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0.0, math.sin(b)], [0.0, 1.0, 0.0], [-math.sin(b), 0.0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0.0], [math.sin(c), math.cos(c), 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


_BIAS_INDEX = [NAMES.index(n) for n in BIASES]
_CROSSTALK_INDEX = [NAMES.index(n) for n in SENSOR_CROSSTALK]


def _mounted_law(params, angles, pos, e, v, g, z, force=None) -> np.ndarray:
    """(N, 6) the law without its offsets and cross-talk, turned into the mounted sensor's frame,
    plus the offsets and the cross-talk, which are the sensor's own and so are not turned
    (``force``: the HEX10's (N, 3) fx, fy, fz readings, N, read only by the cross-talk). With
    every angle 0 it is the law's output (the same terms)."""
    p = np.array(params, dtype=float)
    bias = p[_BIAS_INDEX].copy()
    p[_BIAS_INDEX] = 0.0
    p[_CROSSTALK_INDEX] = 0.0
    out = _model(p, pos.T, e.T, v.T, g.T, z.T, np)
    w = np.stack([np.broadcast_to(c, (len(pos),)) for c in out], axis=1)
    if any(a != 0.0 for a in angles):
        r = mount_rotation(angles)
        w = np.concatenate([w[:, :3] @ r, w[:, 3:] @ r], axis=1)
    w = w + bias
    if force is None and np.any(np.asarray(params, dtype=float)[_CROSSTALK_INDEX] != 0.0):
        raise IdentificationInputError("this prior has the HEX10's cross-talk: pass the "
                                       "HEX10's force readings (hex10_force)")
    leaked = sensor_crosstalk(list(w.T), [float(x) for x in params],
                              None if force is None else np.asarray(force, dtype=float).T)
    return np.stack(leaked, axis=1)


@dataclass
class MountedPrior:
    """A fitted prior on one mount: ``prior`` carries this mount's per-mount values,
    ``angles_rad`` its misalignment (:data:`MOUNT_ANGLES`). Predicts
    ``axis_weights * (R^T law_without_offsets + offsets)``, frames and units of
    :mod:`psmforce.identification.prior`."""

    prior: InternalForcePrior
    angles_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    info: dict = field(default_factory=dict)

    def predict_arrays(self, positions, efforts, velocities, g_hex, direction=None,
                       hex10_force=None) -> np.ndarray:
        self.prior._needs_direction(direction)
        self.prior._needs_reading(hex10_force)
        pos, e, v, g, z = _check_arrays(positions, efforts, velocities, g_hex, direction)
        force = None if hex10_force is None else _check_reading(hex10_force, len(pos))
        return (_mounted_law(self.prior.params, self.angles_rad, pos, e, v, g, z, force)
                * self.prior.axis_weights)

    def predict(self, frame_or_arrays, psm=None) -> np.ndarray:
        """(N, 6) for a recording frame or a dict of :func:`~.prior.arrays_from_frame`."""
        a = frame_or_arrays if isinstance(frame_or_arrays, dict) else arrays_from_frame(
            frame_or_arrays, psm)
        return self.predict_arrays(a["positions"], a["efforts"], a["velocities"], a["g_hex"],
                                   a.get("direction"),
                                   a.get("hex10_force") if self.prior.has_crosstalk else None)

    def per_mount(self) -> dict[str, float]:
        """This mount's values: the per-mount law parameters and the angles (SI)."""
        return {**{n: float(self.prior.params[NAMES.index(n)]) for n in PER_MOUNT},
                **dict(zip(MOUNT_ANGLES, map(float, self.angles_rad)))}


def _stack(recordings, psm):
    from psmforce.io.recording import TIME, read_recording
    parts = []
    for k, rec in enumerate(recordings):
        frame = read_recording(rec) if not hasattr(rec, "columns") else rec
        if all(t in frame.columns for t in TARGETS):
            ext = np.linalg.norm(frame[list(TARGETS)].to_numpy(dtype=float), axis=1)
            loaded = float(np.mean(ext > FREE_SPACE_FORCE_N))
            if loaded > MAX_LOADED_FRACTION:
                raise IdentificationInputError(
                    f"recording {k}: {100 * loaded:.1f} % of its samples carry an external force "
                    f"above {FREE_SPACE_FORCE_N} N; the recalibration takes free-space motion "
                    "only (remove the fixture)")
        try:
            a = arrays_from_frame(frame, psm)
            y, mask = internal_wrench_target(frame)
            t = frame[TIME].to_numpy(dtype=float)
        except KeyError as err:
            raise IdentificationInputError(f"recording {k}: missing column {err}") from None
        parts.append((a, y, mask, t - t[0]))
    cat = {k: np.concatenate([p[0][k] for p in parts]) for k in ("positions", "efforts",
                                                                 "velocities", "g_hex",
                                                                 "direction", "hex10_force")}
    return (cat, np.concatenate([p[1] for p in parts]), np.concatenate([p[2] for p in parts]),
            [p[3] for p in parts])


def drift_basis(times, knot_s: float) -> np.ndarray:
    """(N, K) piecewise-linear ramps, 0 at each recording's start, one per ``knot_s`` of its
    length, block-diagonal over the recordings (``times``: each recording's seconds from its
    start): a slowly wandering force offset that starts where the zero left it."""
    if not knot_s > 0:
        raise IdentificationInputError(f"drift_knot_s must be > 0, got {knot_s!r}")
    blocks = []
    for t in times:
        k = max(1, int(math.ceil(t[-1] / knot_s - 1e-9)))
        edges = knot_s * np.arange(k)
        blocks.append(np.clip((t[:, None] - edges[None, :]) / knot_s, 0.0, 1.0))
    out = np.zeros((sum(len(b) for b in blocks), sum(b.shape[1] for b in blocks)))
    r = c = 0
    for b in blocks:
        out[r:r + len(b), c:c + b.shape[1]] = b
        r, c = r + len(b), c + b.shape[1]
    return out


def recalibrate(prior: InternalForcePrior | MountedPrior, recordings, *, psm=None,
                per_mount=PER_MOUNT, angles=TILT, drift_knot_s: float | None = DRIFT_KNOT_S
                ) -> MountedPrior:
    """Re-estimate the per-mount values of a fitted prior from free-space recordings of the new
    mount (DataFrames of :mod:`psmforce.io.recording` or paths), every shared parameter held.

    ``per_mount``: the law parameters to re-estimate (a subset of :data:`PER_MOUNT`);
    ``angles``: the mount angles to re-estimate (a subset of :data:`MOUNT_ANGLES`; default the
    tilt, :data:`TILT`), the others held at the given prior's (0 for an
    :class:`InternalForcePrior`). ``drift_knot_s``: the force channels' slow drift over the
    recording is fitted alongside as a nuisance (:func:`drift_basis`, not kept: the offsets are
    the values at the recording's start, where the sensor was zeroed); None fits none.

    Refuses (:class:`IdentificationInputError`): no recordings, fewer than
    :data:`~psmforce.identification.prior_law.MIN_SAMPLES` usable samples, a recording with an
    external force (more than :data:`MAX_LOADED_FRACTION` of it above
    :data:`FREE_SPACE_FORCE_N`), a recording that does not roll the instrument over 0.5 rad
    (the pretension is seen in free space only through the roll twist), non-finite data, an
    unknown or shared name in ``per_mount`` / ``angles``, or a prior that is not a prior.
    """
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    if isinstance(prior, MountedPrior):
        base, start_angles = prior.prior, tuple(prior.angles_rad)
    elif isinstance(prior, InternalForcePrior):
        base, start_angles = prior, (0.0, 0.0, 0.0)
    else:
        raise IdentificationInputError(
            f"prior: expected an InternalForcePrior or a MountedPrior, got {type(prior).__name__}")
    if len(np.shape(base.params)) != 1 or len(base.params) != len(NAMES):
        raise IdentificationInputError(f"prior: expected {len(NAMES)} parameters")
    per_mount, angles = tuple(per_mount), tuple(angles)
    wrong = [n for n in per_mount if n not in PER_MOUNT] + [n for n in angles
                                                             if n not in MOUNT_ANGLES]
    if wrong or not (per_mount or angles):
        raise IdentificationInputError(
            f"per_mount must name some of {PER_MOUNT} and angles some of {MOUNT_ANGLES} "
            f"(shared parameters stay as fitted); got {wrong or 'nothing'}")
    recordings = list(recordings)
    if not recordings:
        raise IdentificationInputError("no recordings to recalibrate the prior on (give about "
                                       "two minutes of free-space wrist motion of the new mount)")
    a, y, mask, times = _stack(recordings, psm)
    pos, e, v, g, z = _check_arrays(a["positions"], a["efforts"], a["velocities"], a["g_hex"],
                                    a["direction"])
    if not np.isfinite(y).all():
        raise IdentificationInputError("HEX10 readings have non-finite values")
    force = a["hex10_force"] if base.has_crosstalk else None  # the cross-talk reads the HEX10
    usable = mask.any(axis=1)
    if usable.sum() < MIN_SAMPLES:
        raise IdentificationInputError(f"{int(usable.sum())} usable samples is too short to "
                                       f"recalibrate the prior (need {MIN_SAMPLES})")
    if np.ptp(pos[:, 0]) < 0.5:
        raise IdentificationInputError(
            f"the recordings roll the instrument over {np.ptp(pos[:, 0]):.3g} rad only; the "
            "pretension is seen in free space through the roll twist: roll over at least 0.5 rad")
    drift = (drift_basis(times, drift_knot_s) if drift_knot_s is not None
             else np.zeros((len(y), 0)))
    n_drift = drift.shape[1]

    idx = [NAMES.index(n) for n in per_mount]
    ang_idx = [MOUNT_ANGLES.index(n) for n in angles]
    free = list(per_mount) + list(angles)
    lo = np.array([PARAMETERS[i][2] for i in idx] + [-MAX_MOUNT_ANGLE_RAD] * len(angles))
    hi = np.array([PARAMETERS[i][3] for i in idx] + [MAX_MOUNT_ANGLE_RAD] * len(angles))
    x0 = np.array([base.params[i] for i in idx] + [start_angles[i] for i in ang_idx])
    x0 = np.clip(x0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
    span = np.maximum(hi - lo, 1e-12)
    # drift ramps (N per knot interval) of the three force channels, bounded by the offsets'
    lo_all = np.concatenate([lo, np.full(3 * n_drift, -5.0)])
    hi_all = np.concatenate([hi, np.full(3 * n_drift, 5.0)])
    x0_all = np.concatenate([x0, np.zeros(3 * n_drift)])
    # Channel scales as the full fit: each channel's spread in the data, floored at the noise.
    n_ok = np.maximum(mask.sum(0), 1)
    mean = (y * mask).sum(0) / n_ok
    scale = np.maximum(np.sqrt((mask * (y - mean) ** 2).sum(0) / n_ok), [0.02] * 3 + [2e-4] * 3)
    weight = mask / scale

    def unpack(x):
        p = base.params.astype(float).copy()
        p[idx] = x[:len(idx)]
        ang = list(start_angles)
        for k, i in enumerate(ang_idx):
            ang[i] = x[len(idx) + k]
        return p, tuple(ang), x[len(free):].reshape(3, n_drift)

    i_bfz = NAMES.index("bias_fz")

    def residual(x):
        p, ang, ramps = unpack(x)
        w = _mounted_law(p, ang, pos, e, v, g, z, force)
        if any(a != 0.0 for a in ang):
            # What a tilt leaks into the lateral channels is the true axial force, which the
            # reading shows (less its offset) and the law only approximates: the leak is fitted
            # on the reading, so the law's axial error does not bias the tilt.
            law_fz = w[:, 2] - p[i_bfz]
            leak = (y[:, 2] - p[i_bfz] - law_fz) * mask[:, 2]
            w[:, :2] += leak[:, None] * mount_rotation(ang)[2, :2]
        w[:, :3] += drift @ ramps.T
        return ((w - y) * weight).ravel()

    sol = least_squares(residual, x0_all, bounds=(lo_all, hi_all),
                        x_scale=np.concatenate([span * 1e-3, np.full(3 * n_drift, 0.01)]),
                        method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    p, ang, _ = unpack(sol.x)
    dof = max(int(mask.sum()) - len(sol.x), 1)
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * (2.0 * sol.cost / dof)
        se = np.sqrt(np.clip(np.diag(cov)[:len(free)], 0.0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(free), np.nan)
    out = InternalForcePrior(params=p, converged=bool(base.converged and sol.success),
                             info={**base.info}, insertion=base.insertion,
                             axis_weights=base.axis_weights.copy())
    before = {**{n: float(base.params[NAMES.index(n)]) for n in PER_MOUNT},
              **dict(zip(MOUNT_ANGLES, map(float, start_angles)))}
    after = {**{n: float(p[NAMES.index(n)]) for n in PER_MOUNT},
             **dict(zip(MOUNT_ANGLES, map(float, ang)))}
    info = {"re_estimated": free, "held": [n for n in NAMES if n not in per_mount]
            + [n for n in MOUNT_ANGLES if n not in angles],
            "before": before, "after": after,
            "standard_errors": {n: float(s) for n, s in zip(free, se)},
            "at_bound": [n for n, x, l, h in zip(free, sol.x, lo, hi)
                         if min(x - l, h - x) <= 1e-3 * (h - l)],
            "drift_knot_s": drift_knot_s, "drift_terms": 3 * n_drift,
            "n_samples": int(usable.sum()),
            "solver": "scipy least_squares (trf)", "solver_status": sol.message,
            "converged": bool(sol.success), "fit_time_s": time.perf_counter() - t0}
    out.info = {**base.info, "recalibration": info}
    return MountedPrior(out, tuple(float(x) for x in ang), info)
