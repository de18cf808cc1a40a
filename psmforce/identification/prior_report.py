"""What ``psmforce fit-prior`` runs: fit the internal-force prior on a simulated dataset, score it
on the free-space test trials against the project's targets, gate poor fits, save it.

The prior itself: :mod:`.prior`.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import (HELD_BY_READING_REASON, NAMES, InternalForcePrior,
                                           channel_metrics)
from psmforce.identification.prior_selection import all_free_line, fit_identified, verdict_line
from psmforce.robot.kinematics import PSM
from psmforce.io.recording import FREE_SPACE, HEX10, HEX10_FORCE, list_recordings, read_recording


def _dataset_trials(data_dir: Path, split: str, conditions) -> list[Path]:
    if not (data_dir / "metadata.json").is_file():
        raise IdentificationInputError(f"{data_dir}: no metadata.json (not a simulated dataset)")
    return [r.path for r in list_recordings(data_dir)
            if r.split == split and r.condition in conditions]


POOR_FIT_RMS_N = 2.0
"""A prior whose held-out (test Free) RMS residual exceeds this on any force axis is a poor fit
and is saved only on request (``accept_poor_fit``; ``--accept-poor-fit``): 8 % of the HEX10's
nominal range, beyond what the hybrid's network can be asked to correct, and more than twice the
free-space fz variation itself (std 0.83 N on the bench below), i.e. worse than predicting a
constant. Measured (``studies/prior_accuracy.py``, scale 0.05, seed 1, test Free fz RMS): the
default (calibrated) bench, Free-only 0.26 N; with loaded trials (``use_loaded``) 3.4 N, which
the gate rejects: the wrist discs' stiction makes the motor effort differ from the cable torque
by up to its breakaway level, 5 N of axial force in the slack regime that loaded trials reach;
the bench without its effort-channel effects 0.07 / 0.24 N; one training trial with fz = 1e6 N
far beyond. R^2 is no gate: on a channel that is pure noise a good fit has R^2 near 0."""


def fit_prior_cli(data_dir, out_json, *, use_loaded: bool = False,
                  accept_poor_fit: bool = True, identify: bool = False,
                  inputs: str = "efforts", crosstalk: bool | str | None = None) -> dict:
    """What ``psmforce fit-prior`` runs: fit on the dataset's train split (Free trials; with
    ``use_loaded`` also Traction and Palpation with the known force subtracted, which excites the
    slack regime and so the pulley radii), evaluate on test/Free, save the JSON if converged.

    Free-only is the default: on the full simulator the loaded regime carries capstan and
    elasticity effects outside the model class, which pull the free-space fit off.

    The report's ``poor_fit`` says whether the test Free force RMS exceeds
    :data:`POOR_FIT_RMS_N`; ``accept_poor_fit=False`` (the CLI's default) then saves nothing
    and says why in ``model_not_saved_reason``.

    ``identify`` (what ``psmforce fit-prior`` passes unless ``--all-free``): the fit holds at
    their design values the parameters its identifiability report calls not identifiable, and
    refits the rest (:func:`psmforce.identification.prior_selection.fit_identified`); ``False``
    (the library's default, a predictor for the hybrid as before) fits every parameter its
    reading does not hold (:data:`~psmforce.identification.prior.HELD_BY_READING`), and the verdict
    says it is a curve fit and which values its report does not identify. ``verdict``: one line naming the
    identified, the fixed and the at-bound parameters, then the held-out figures against the
    gate and the targets (what ``psmforce fit-prior`` prints). ``inputs="load_path"``
    (``--load-path``): the law reads the cables from the trials' known tip force, not from the
    motor efforts (:mod:`psmforce.identification.load_path`): an identification of the
    instrument, not a prior an estimator can run on; with ``identify`` its wrist is sagged with
    the fit's own values (``report["wrist_sag"]``, :func:`~psmforce.identification.
    prior_selection.fit_identified`), without it with the design's. ``crosstalk``: the
    sensor's cross-talk the law fits (:data:`~psmforce.identification.prior.CROSSTALK_CHOICES`;
    None: as the reading does)."""
    data_dir = Path(data_dir)
    conds = (FREE_SPACE, "Traction", "Palpation") if use_loaded else (FREE_SPACE,)
    train = _dataset_trials(data_dir, "train", conds)
    test = _dataset_trials(data_dir, "test", (FREE_SPACE,))
    if not train:
        raise IdentificationInputError(f"{data_dir}: no training trials for {conds}")
    psm = PSM()
    provenance = {"data_dir": str(data_dir),
                  "train_trials": [str(p.relative_to(data_dir)) for p in train]}
    frames = [read_recording(p) for p in train]
    t0 = time.perf_counter()
    if identify:
        prior = fit_identified(frames, psm=psm, provenance=provenance, inputs=inputs,
                               crosstalk=crosstalk)
        selection = prior.info["selection"]
    else:
        prior = InternalForcePrior.fit(frames, psm=psm, provenance=provenance, inputs=inputs,
                                       crosstalk=crosstalk)
        listed = sorted(prior.info["identifiability"]["not_identifiable"])
        held = prior.info["fixed"]  # by the reading (HELD_BY_READING)
        selection = {"identified": [n for n in NAMES if n not in listed and n not in held],
                     "fixed": {n: {"value": x, "reason": HELD_BY_READING_REASON[n]}
                               for n, x in held.items()},
                     "still_not_identifiable": listed, "at_bound": prior.info["bounds_hit"],
                     "rounds": []}
    report = {"data_dir": str(data_dir), "conditions": list(conds), "inputs": inputs,
              "converged": prior.converged,
              "solver_status": prior.info["solver_status"],
              "fit_time_s": time.perf_counter() - t0,
              "parameters": dict(zip(NAMES, prior.params.tolist())),
              "bounds_hit": prior.info["bounds_hit"],
              "identified": selection["identified"],
              "fixed": {n: f["value"] if isinstance(f, dict) else f
                        for n, f in selection["fixed"].items()},
              "not_identifiable": prior.info["identifiability"]["not_identifiable"],
              "insertion": prior.insertion.to_dict() if prior.insertion is not None else None,
              **({"wrist_sag": selection["sag"]} if "sag" in selection else {})}
    if test:
        frames = [read_recording(p) for p in test]
        y = np.concatenate([f[list(HEX10)].to_numpy(dtype=float) for f in frames])
        y_hat = np.concatenate([prior.predict(f, psm) for f in frames])
        report["test_free_metrics"] = m = channel_metrics(y, y_hat)
        prior.info["test_free_metrics"] = m
        lateral, axial = HEX10_FORCE[:2], HEX10_FORCE[2]
        r2 = m[axial]["r2"]
        report["targets_not_met"] = (
            ([] if r2 is not None and r2 >= 0.9
             else [f"test Free {axial} R2 {r2 if r2 is None else format(r2, '.3g')} < 0.90"])
            + [f"test Free {c} RMS {m[c]['rms']:.3f} N >= 0.3 N" for c in lateral
               if m[c]["rms"] >= 0.3])
        worst = max(m[c]["rms"] for c in HEX10_FORCE)
        report["poor_fit"] = not worst <= POOR_FIT_RMS_N  # NaN is poor too
        report["poor_fit_threshold_rms_n"] = POOR_FIT_RMS_N
    report["verdict"] = verdict(report, verdict_line(selection) if identify
                                else all_free_line(selection))
    prior.info["verdict"] = report["verdict"]
    if not prior.converged:
        report["model"] = None
        report["model_not_saved_reason"] = f"fit did not converge ({prior.info['solver_status']})"
    elif report.get("poor_fit") and not accept_poor_fit:
        report["model"] = None
        report["model_not_saved_reason"] = (
            f"poor fit: test Free force RMS {worst:.3g} N > {POOR_FIT_RMS_N:g} N")
    else:
        prior.save(out_json)
        report["model"] = str(out_json)
    return report


def verdict(report: dict, parameters: str = "") -> str:
    """The line ``psmforce fit-prior`` prints after "verdict: ": ``parameters`` (the identified,
    fixed and at-bound parameters, :func:`~psmforce.identification.prior_selection.
    verdict_line`), then the held-out force RMS against :data:`POOR_FIT_RMS_N` and the targets
    missed, from a :func:`fit_prior_cli` report."""
    parts = [parameters] if parameters else []
    metrics = report.get("test_free_metrics")
    if metrics:
        worst = max(metrics[c]["rms"] for c in HEX10_FORCE)
        poor = report.get("poor_fit")
        parts.append(("POOR FIT: " if poor else "") + f"held-out force RMS {worst:.3g} N "
                     + ("above" if poor else "within") + f" the {POOR_FIT_RMS_N:g} N poor-fit gate")
        missed = report.get("targets_not_met") or []
        parts.append("targets NOT met: " + "; ".join(missed) if missed else "meets its targets")
    else:
        parts.append("not scored (no test/Free recordings), no gate applied")
    return "; ".join(parts)
