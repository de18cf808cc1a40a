"""After a re-mount: a trained hybrid's prior recalibrated per mount (``psmforce remount``;
issue 44, item 4; docs/ati_free.md sections 3 and 5).

The paper resets before every trial: the instrument is removed, re-attached and the HEX10
zeroed. That changes the mount (the cables' pretension as the discs re-seat, the sensor's
offsets as it is zeroed again), not the instrument nor what the network learned on it.
:func:`recalibrate_checkpoint` therefore re-estimates only the per-mount values of the
checkpoint's internal-force prior, :data:`RE_ESTIMATED` (the pretension and the three HEX10 force
offsets, ``prior_remount.FORCE_PER_MOUNT``), on free-space recordings of the new mount, by
:func:`psmforce.identification.prior_remount.recalibrate` (``angles=()``), and writes a new
checkpoint with that prior and everything else of the old one: every other law parameter
(pulley radii, twist gain, asymmetries, path term, distal mass and lever, cable radius, the
moment offsets), the insertion model, the network's weights, its features and scalers, its
training provenance. The new checkpoint's provenance appends one record to ``remounts``
(recordings and their SHA-256, the values before and after, standard errors, what was held).

Why ``recalibrate`` and not ``calibrate(..., free_space=True, prior_refit="per_mount")``, which
refits the prior the same way: ``calibrate`` also finetunes the network's last block on the
recordings, which a re-mount gives no reason to do (free space carries no tip force to learn
from), and it needs two free-space recordings (one to fit on, one to stop the finetuning on)
where the procedure records one. Why no tilt (``prior_remount.TILT``, which the study of
docs/ati_free.md section 3 fits too): a checkpoint stores an ``InternalForcePrior``, whose law
has no mount angles (only ``prior_remount.MountedPrior`` has them), so a fitted tilt could be
neither stored nor applied by ``serve``, ``replay``, ``evaluate`` or ``export``; fitting the
offsets beside a tilt that is then dropped would leave them fitted for another model. The
pretension and force offsets are fitted without it, as ``calibrate``'s per-mount refit does.

**The recordings** (:func:`remount_recordings`): ``data`` is one recording CSV or a folder; from
a folder, the recordings whose condition is ``Free`` (``DIR/[SPLIT/]Free/*.csv``, or a
``metadata.json`` that says so), else the CSV files directly in it, all taken as free space
(``recalibrate`` refuses one whose ATI columns, where it has them, show a load). Refused, in one
line each (:class:`RemountError`, a ValueError): a missing path, no free-space recording, too
few samples or too little roll (``recalibrate``'s checks), a checkpoint without a prior, a fit
that does not converge, an output that exists (there is no overwrite option: a re-mount writes a
new file) or is the checkpoint itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from psmforce.identification.prior_remount import FORCE_PER_MOUNT

RE_ESTIMATED = FORCE_PER_MOUNT
"""What a re-mount recalibration re-estimates: the pretension and the three force offsets, the
set docs/ati_free.md section 3 chose (the moment offsets held)."""
SUGGESTED_MINUTES = 2.0
"""The recording the procedure asks for and the study measured (``psmforce excitation
--minutes 2``, docs/ati_free.md section 3); less is allowed and said."""
METHOD = ("psmforce.identification.prior_remount.recalibrate(prior, recordings, "
          "per_mount=FORCE_PER_MOUNT, angles=()): bounded least squares over the six HEX10 "
          "channels, the force channels' drift over the recording fitted alongside as a nuisance")


class RemountError(ValueError):
    """A re-mount recalibration that cannot run as asked; the message says why."""


def remount_recordings(data) -> list[tuple[str, Path]]:
    """(name, path) of the free-space recordings of ``data`` (module docstring), names relative
    to ``data`` (a file: its own name)."""
    from psmforce.io.recording import FREE_SPACE, RecordingError, list_recordings
    root = Path(data)
    try:
        listed = list_recordings(root)
    except RecordingError as err:
        raise RemountError(str(err)) from None
    chosen = [r for r in listed if r.condition == FREE_SPACE] or [
        r for r in listed if r.condition == "" and r.split == ""]
    if not chosen:
        found = sorted({r.condition for r in listed})
        raise RemountError(f"{root}: no free-space recordings: found conditions {found}; record "
                           "the excitation in free space and put its CSV directly in the folder "
                           f"or under {FREE_SPACE}/ (docs/ati_free.md section 5)")
    return [(r.path.name if root.is_file() else r.path.relative_to(root).as_posix(), r.path)
            for r in chosen]


def check_out(out, checkpoint) -> None:
    """An output the re-mount may write: new (no overwrite option: never over a checkpoint,
    least of all its input), a name the file system holds."""
    from psmforce.core.files import check_name, check_output
    out = Path(out)
    check_name(out)
    check_output(out)  # a link, folder, pipe or device: refused as such
    if Path(checkpoint).exists() and out.resolve() == Path(checkpoint).resolve():
        raise RemountError(f"{out} is the checkpoint being recalibrated: a re-mount writes a "
                           "new checkpoint (give another file)")
    if out.exists() or out.is_symlink():
        raise RemountError(f"{out} exists: a re-mount writes a new checkpoint, never over one "
                           "(give a new file name)")


def _free_rms(prior, frames) -> dict:
    """Per force axis, the RMS (N) of the HEX10 reading (less a known external force) minus the
    prior over the recordings: how far the prior is from this mount in free space."""
    from psmforce.identification.prior import internal_wrench_target
    err = []
    for frame in frames:
        y, mask = internal_wrench_target(frame)
        keep = mask[:, :3].all(axis=1)
        err.append((prior.predict(frame) - y)[keep, :3])
    e = np.concatenate(err)
    return {a: float(np.sqrt(np.mean(e[:, k] ** 2))) for k, a in enumerate(("fx", "fy", "fz"))}


def recalibrate_checkpoint(checkpoint, data, out) -> dict:
    """Re-estimate the per-mount values of ``checkpoint``'s prior on the free-space recordings of
    ``data`` and write the new checkpoint ``out`` (module docstring). Returns the record the new
    checkpoint's provenance appends to ``remounts``, with ``out``."""
    from psmforce.estimators.data.hybrid_inputs import prior_to_json
    from psmforce.estimators.data.sanity import file_sha256
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.identification.errors import IdentificationInputError, NotConvergedError
    from psmforce.identification.prior import NAMES
    from psmforce.identification.prior_remount import MOUNT_ANGLES, recalibrate
    from psmforce.io.recording import TIME, read_recording
    check_out(out, checkpoint)
    ckpt = load_checkpoint(checkpoint)
    if ckpt.prior_json is None:
        raise RemountError(f"{checkpoint}: a '{ckpt.model_name}' model without an internal-force "
                           "prior: nothing to recalibrate after a re-mount (a hybrid has one)")
    if ckpt.physics_prior_json is not None:  # two priors, one mount: not re-estimated apart
        raise RemountError(f"{checkpoint}: holds a prior of its physics-only axes' own "
                           f"(calibrate --network-prior trained); re-mounting it is not "
                           f"supported: calibrate the checkpoint it came from again on this "
                           f"mount's recordings")
    old = ckpt.prior()
    recordings = remount_recordings(data)
    frames = [read_recording(path) for _, path in recordings]
    try:
        mounted = recalibrate(old, frames, per_mount=RE_ESTIMATED, angles=())
        se = mounted.info["standard_errors"]  # NaN where the fit's Jacobian was singular:
        se.update({n: None for n, v in se.items() if not np.isfinite(v)})  # JSON has no NaN
        prior_json = prior_to_json(mounted.prior)
    except IdentificationInputError as err:
        raise RemountError(f"{data}: {err}") from None
    except NotConvergedError:
        raise RemountError(f"{data}: the recalibration did not converge "
                           f"({mounted.info['solver_status']}); record the excitation again, "
                           f"{SUGGESTED_MINUTES:g} minutes in free space") from None
    info = mounted.info
    minutes = [float(f[TIME].iloc[-1] - f[TIME].iloc[0]) / 60.0 for f in frames]
    previous = ckpt.provenance.get("remounts", [])
    record = {
        "checkpoint": str(checkpoint), "data": str(data), "method": METHOD,
        "recordings": [{"path": name, "sha256": file_sha256(path), "minutes": round(m, 4),
                        "samples": len(f)}
                       for (name, path), m, f in zip(recordings, minutes, frames)],
        "minutes": round(sum(minutes), 4), "n_samples": info["n_samples"],
        "re_estimated": list(RE_ESTIMATED),
        "held": [n for n in NAMES if n not in RE_ESTIMATED],
        "not_fitted": {"mount angles": list(MOUNT_ANGLES), "why": "the checkpoint's prior has "
                       "no mount angles (psmforce.estimators.training.remount)"},
        "kept": "the insertion model, the network's weights, features and scalers, the "
                "training provenance",
        "before": {n: info["before"][n] for n in RE_ESTIMATED},
        "after": {n: info["after"][n] for n in RE_ESTIMATED},
        "standard_errors": info["standard_errors"], "at_bound": info["at_bound"],
        "converged": info["converged"], "solver_status": info["solver_status"],
        "drift_knot_s": info["drift_knot_s"], "fit_time_s": info["fit_time_s"],
        "free_space_rms_n": {"before": _free_rms(old, frames),
                             "after": _free_rms(mounted.prior, frames),
                             "note": "on the recordings the recalibration fitted (in-sample)"}}
    ckpt.prior_json = prior_json
    ckpt.provenance = {**ckpt.provenance,
                       "remounts": [*(previous if isinstance(previous, list) else []), record]}
    check_out(out, checkpoint)  # again: nothing may have appeared there meanwhile
    ckpt.save(out)  # atomic (psmforce.core.files.atomic_path)
    return {**record, "out": str(out)}
