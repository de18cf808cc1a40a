"""Every parameter of the cable transmission with a declared role, and identifiability measured
by a bootstrap over files rather than assumed from white noise.

Roles (one table, :data:`DESIGN`, :data:`.model.PER_SESSION`, and what :func:`identify`
decides):

``design``
    known from the instrument and the bench, never fitted: the 35:1 gearbox, the encoders'
    counts per revolution, the torque sensors' scale (:mod:`.recording`), the drive's current per
    unit command (:mod:`.checks`).
``shared``
    a constant of the instrument, fitted once over every recording and configuration given.
``per_session``
    re-estimated for each session from a short segment (:meth:`.model.CableTransmission.recalibrate`):
    the cable pretension and the pair's asymmetry, the torque sensor's zero and the encoders'
    zero change when an instrument is re-mounted.
``fixed: not excited``
    a shared parameter whose input never varies in the data: ``capstan_mu_pitch`` and
    ``capstan_mu_abs_pitch`` (the wrist pitch's wrap, :mod:`.model`) when no recording of the
    fit is pitched; held at 0
    by :meth:`.model.CableTransmission.fit` itself (``info["unexcited"]``).
``fixed: switched off``
    a wrist-pitch wrap term the fit was not told to fit (``pitch_wrap``, :mod:`.model`): the
    default model holds both at 0.
``fixed``
    a shared parameter the data cannot pin down: its bootstrap relative standard deviation
    exceeds :data:`RELATIVE_SD_LIMIT` (or the Fisher tie of :mod:`.model` fixed it); it is held
    at its design value (:data:`FALLBACK`) and the fit is redone without it.

The bootstrap resamples whole files with replacement within each session (a file is the unit
of independent noise: residuals inside a file are coloured by the hysteresis) and refits the
torque path from the fitted values, the widths kept; the spread of each parameter over the
resamples is its uncertainty. "At a bound" is one rule for every parameter and width
(:func:`.model.at_bound`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from psmforce.identification.transmission.model import (PITCH_TERMS, TORQUE_NAMES,
                                                        TORQUE_PARAMETERS, CableTransmission,
                                                        at_bound)
from psmforce.identification.transmission.recording import TransmissionRecording

DESIGN = {
    "gearbox_ratio": (35.0, "1", "the motor's 35:1 gearbox (the dataset's README)"),
    "motor_counts_per_rev": (4196 * 35, "counts", "motor encoder through the gearbox"),
    "spindle_counts_per_rev": (8192, "counts", "input-spindle CUI encoder"),
    "jaw_counts_per_rev": (4000, "counts", "front-end Maxon encoder"),
    "futek_nm_per_count": (0.000039811, "Nm", "both Futek torque sensors"),
    "current_per_command_a": (2.05, "A", "the drive's current gain (.checks)"),
    "pitch_wrap_per_rad": (1.0, "rad/rad", "each jaw cable's wrap over the pitch idlers changes "
                           "1:1 with the wrist pitch: +q / -q (antagonistic routing, "
                           "capstan_mu_pitch) or +|q| each (symmetric, capstan_mu_abs_pitch); "
                           "the parameter is the friction per rad of that wrap"),
}
FALLBACK = {**{p[0]: 0.0 for p in TORQUE_PARAMETERS}, "current_gain": 0.7, "capstan_mu": 0.4}
"""Design values a parameter the data cannot pin down is held at: no term (0) for the
corrections, the nominal figures for the current gain (Maxon k_t x 35 x efficiency) and the
capstan friction."""
RELATIVE_SD_LIMIT = 0.3
BOOTSTRAP_RESAMPLES = 20


def bootstrap(model: CableTransmission, recordings: Sequence[TransmissionRecording], *,
              resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0) -> dict:
    """Refit ``model``'s free parameters on ``resamples`` resamplings of ``recordings`` (files
    drawn with replacement within each session; widths and fixed values kept). Returns per
    parameter (shared ones by name, per-session ones as ``name[session]``): the fitted value,
    the bootstrap standard deviation, the relative standard deviation and the 5-95 % interval."""
    rng = np.random.default_rng(seed)
    by_session: dict[str, list] = {}
    for r in recordings:
        by_session.setdefault(r.session, []).append(r)
    fixed = {n: float(v) for n, v in zip(TORQUE_NAMES, model.torque) if n in model.fixed}
    draws = []
    for _ in range(resamples):
        sample = [recs[k] for recs in by_session.values()
                  for k in rng.integers(0, len(recs), len(recs))]
        refit = CableTransmission.fit(sample, initial=model, per_session=model.per_session,
                                      fixed=fixed, current_source=model.current_source,
                                      pitch_wrap=model.info.get("pitch_wrap", ()))
        draws.append(_flat(refit))
    values = _flat(model)
    out = {}
    for name, value in values.items():
        xs = np.array([d[name] for d in draws if name in d])
        sd = float(xs.std(ddof=1)) if len(xs) > 1 else float("nan")
        out[name] = {"value": value, "sd": sd, "relative_sd": sd / max(abs(value), 1e-12),
                     "interval_5_95": [float(np.percentile(xs, 5)), float(np.percentile(xs, 95))]}
    return {"resamples": resamples, "seed": seed, "unit": "whole files within each session",
            "parameters": out}


def _flat(model: CableTransmission) -> dict:
    """The free torque parameters by name (shared) and ``name[session]`` (per session)."""
    out = {n: float(v) for n, v in zip(TORQUE_NAMES, model.torque)
           if n not in model.fixed and n not in model.per_session}
    for session, values in model.sessions.items():
        out.update({f"{n}[{session}]": float(v) for n, v in values.items()
                    if n in TORQUE_NAMES})
    return out


def identify(recordings: Sequence[TransmissionRecording], *,
             validation: Sequence[TransmissionRecording] = (),
             initial: CableTransmission | None = None, resamples: int = BOOTSTRAP_RESAMPLES,
             seed: int = 0, current_source: str = "measured",
             declared_fixed: dict | None = None,
             pitch_wrap: Sequence[str] = ()) -> tuple[CableTransmission, dict]:
    """Fit (``declared_fixed`` held from the start), bootstrap, fix the shared parameters the
    bootstrap cannot pin down at their design values (:data:`FALLBACK`), refit, and bootstrap
    again. Returns the model and its roles report (:func:`roles_table` and both
    bootstraps)."""
    declared = dict(declared_fixed or {})
    model = CableTransmission.fit(recordings, validation=validation, initial=initial,
                                  fixed=declared, current_source=current_source,
                                  pitch_wrap=pitch_wrap)
    first = bootstrap(model, recordings, resamples=resamples, seed=seed)
    loose = sorted(n for n, b in first["parameters"].items()
                   if n in TORQUE_NAMES and b["relative_sd"] > RELATIVE_SD_LIMIT)
    if loose:
        fixed = {**{n: float(v) for n, v in zip(TORQUE_NAMES, model.torque) if n in model.fixed},
                 **{n: FALLBACK[n] for n in loose}}
        model = CableTransmission.fit(recordings, validation=validation, initial=model,
                                      fixed=fixed, current_source=current_source,
                                      pitch_wrap=pitch_wrap)
        model.info["not_identifiable"] = loose
        final = bootstrap(model, recordings, resamples=resamples, seed=seed)
    else:
        model.info["not_identifiable"] = []
        final = first
    model.info["declared_fixed"] = sorted(declared)
    report = {"first_bootstrap": first, "bootstrap": final, "not_identifiable": loose,
              "relative_sd_limit": RELATIVE_SD_LIMIT, "roles": roles_table(model, final)}
    model.info["roles"] = report["roles"]
    return model, report


def roles_table(model: CableTransmission, boot: dict | None = None) -> list[dict]:
    """One row per parameter: name, role, value(s), unit, bounds, bootstrap relative sd, and
    whether it sits at a bound (:func:`.model.at_bound`, the one rule)."""
    rows = [{"name": n, "role": "design", "value": v, "unit": u, "note": note}
            for n, (v, u, note) in DESIGN.items()]
    boot_p = (boot or {}).get("parameters", {})
    declared = set(model.info.get("declared_fixed", []))
    unexcited = set(model.info.get("unexcited", [])) - declared
    switched_off = (((set(PITCH_TERMS) - set(model.info["pitch_wrap"])) & set(model.fixed))
                    - declared - unexcited if "pitch_wrap" in model.info else set())
    tied = (set(model.fixed) - set(model.info.get("not_identifiable", [])) - declared
            - unexcited - switched_off)
    for (name, unit, lo, hi, _), value in zip(TORQUE_PARAMETERS, model.torque):
        if name in model.per_session:
            per = {s: v[name] for s, v in model.sessions.items() if name in v}
            rows.append({"name": name, "role": "per_session", "value": per, "unit": unit,
                         "bounds": [lo, hi],
                         "relative_sd": {s: boot_p.get(f"{name}[{s}]", {}).get("relative_sd")
                                         for s in per},
                         "at_bound": sorted(s for s, v in per.items() if at_bound(v, lo, hi))})
            continue
        role = ("fixed: not identifiable" if name in model.info.get("not_identifiable", [])
                else "fixed: declared" if name in declared
                else "fixed: not excited" if name in unexcited
                else "fixed: switched off" if name in switched_off
                else "fixed: tied" if name in tied else "shared")
        rows.append({"name": name, "role": role, "value": float(value), "unit": unit,
                     "bounds": [lo, hi],
                     "relative_sd": boot_p.get(name, {}).get("relative_sd"),
                     "at_bound": role == "shared" and at_bound(float(value), lo, hi)})
    for name, value in zip(("ratio", "compliance_torque", "compliance_current", "windup"),
                           model.angle[:4]):
        rows.append({"name": name, "role": "shared", "value": float(value),
                     "unit": {"ratio": "1", "compliance_torque": "rad/Nm",
                              "compliance_current": "rad/A", "windup": "rad"}[name],
                     "note": "angle path: exact least squares"})
    if "angle_offset" in model.per_session:
        rows.append({"name": "angle_offset", "role": "per_session", "unit": "rad",
                     "value": {s: v["angle_offset"] for s, v in model.sessions.items()
                               if "angle_offset" in v}})
    for name in ("presliding_rad", "hold_rad", "backlash_rad"):
        rows.append({"name": name, "role": "shared", "value": getattr(model, name),
                     "unit": "rad", "note": "chosen on a grid",
                     "at_bound": name in model.info.get("identifiability", {}).get("at_bound",
                                                                                  [])})
    return rows
