"""Parameter recovery of the internal-force prior on an in-family bench (docs/identification.md,
section 2.1, "Parameter recovery on an in-family bench").

The in-family bench is the simulator with the switches and instrument below, so that the HEX10
wrench it simulates is, up to sensor noise, a member of the prior's family
(:mod:`psmforce.identification.prior`) and the wrist efforts the prior reads are the cable
torques plus white noise and current quantisation; :func:`prior_truth` maps the bench's
parameters onto the prior's. Sensor noise stays on: it is what decides what is identifiable.
This module reads the simulator's truth for the comparison only; the prior itself does not.

The default bench (:func:`recover_default`, docs/identification.md section 2.1, "On the default
bench"): ``psmforce simulate`` then ``psmforce fit-prior`` as a user runs them, the fit holding
what its report calls unidentifiable at design values
(:mod:`psmforce.identification.prior_selection`), compared with the bench's parameters
(:func:`default_bench_truth`) by :func:`compare_selection`.

Size: the two benches (in-family and default) share the comparison with the truth (the truth
maps, the rule a miss is judged by, :func:`judge`), so they stay in one module rather than two
that would import each other's halves.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from psmforce.identification.prior import NAMES, InternalForcePrior
from psmforce.identification.prior_law import CROSSTALK, CROSSTALK_ENTRIES, CROSSTALK_LATERAL
from psmforce.identification.prior_identifiability import (OFFSET_RESOLUTION, RECOVERY_TOLERANCE,
                                                           recovered)
from psmforce.robot.kinematics import PSM
from psmforce.sim.params import Effects, InstrumentParams

SWITCHES = {
    "pretension": "on: T_tot/6 per cable (prior: pretension_total)",
    "slack": "on: S = max(2 T0 + a D, |D|) (prior: its smooth max, 0.05 N wide)",
    "cable_asymmetry": "on: S = 2 T0 + a D when taut (prior: asymmetry_pitch / _blade)",
    "roll_twist": "on: T0 (1 + g roll^2) (prior: twist_gain); its capstan part needs capstan",
    "elasticity": "on: the wrist deflects; the efforts and the cables see the same deflected "
                  "load, the prior uses neither the deflection nor the wrist angles but pitch",
    "distal_gravity": "on: the distal mass on the shaft axis (prior: distal_mass, "
                      "distal_com_distance); the jaw mass is moved there (in_family_instrument)",
    "hex10_bias": "on: constant force offset (prior: bias_fx..fz)",
    "sensor_noise": "on: HEX10, ATI and joint-effort white noise (the prior reads the noisy "
                    "efforts: errors in variables)",
    "encoder_quantisation": "on: sensor resolution",
    "current_quantisation": "on: effort resolution, 0.1 mNm at the discs",
    "arm_dynamics": "on: arm joints only (the prior reads no arm effort); its wrist-disc "
                    "friction is drive_friction",
    "contact_friction": "on: part of the external force, which the ATI measures and the fit "
                        "subtracts",
    "capstan": "off: multiplicative exp(mu z) with Dahl memory, outside the family (the prior's "
               "direction_tension is a stand-in; truth 0)",
    "hysteresis": "off: only drives capstan and pin friction",
    "pin_friction": "off: not in the family",
    "pitch_path_mismatch": "off: the bench adds it to the blade pretension (it moves the slack "
                           "threshold), the prior outside the max (truth 0)",
    "hex10_crosstalk": "off: the prior's cross-talk is the axial force's alone (the matrix's fz "
                       "column), and the efforts reading holds it",
    "hex10_drift": "off: a random walk, not a constant bias",
    "hex10_range_error": "off: not in the family (and |f| < 25 N mostly)",
    "drive_friction": "off: the wrist discs' friction is proximal of the HEX10: in the efforts, "
                      "not in the cables",
    "coloured_effort_noise": "off: an effort disturbance that tensions no cable",
    "remount_offsets": "off: a constant effort offset that tensions no cable",
}
"""Each Effects switch of the in-family bench and why (on / off)."""

IN_FAMILY_EFFECTS = Effects(**{name: why.startswith("on") for name, why in SWITCHES.items()})

RECOVERY_FIXED: dict[str, float] = {}
"""Nothing is held in the recovery fit. The cable radius is not identifiable (it is fitted from
moments only where no external force acts; with no load on the wrist the pair differentials there
are the efforts' noise alone, input reliability about 0, and least squares shrinks it to zero),
but holding it at the datasheet's 1.2 mm (``DATASHEET``) is worse: the moments then carry
rho x the effort noise (about 5e-4 Nm, 2.4x the moment noise) and the fit shrinks the pair
differentials instead, pulley radii to their upper bound and the pretension to zero
(docs/identification.md, section 2.1)."""


def in_family_instrument(base: InstrumentParams | None = None) -> InstrumentParams:
    """``base`` (nominal by default) made in-family: the jaw mass moved onto the distal body on
    the shaft axis (the prior has one distal mass on the axis; the jaws' moves with the wrist
    angles), the two blade pairs given one asymmetry (their mean: the prior ties them), the
    cables along the shaft where they cross the section (no lateral force)."""
    base = base or InstrumentParams()
    a = base.cable_asymmetry
    blade = 0.5 * (a[1] + a[2])
    return dataclasses.replace(base, jaw_mass_kg=0.0,
                               distal_body_mass_kg=base.distal_body_mass_kg + base.jaw_mass_kg, cable_asymmetry=(a[0], blade, blade),
                               cable_crossing_angle_rad=0.0)


def prior_truth(instrument: InstrumentParams, psm: PSM | None = None) -> dict[str, float]:
    """The prior's parameters (SI) of an in-family bench with ``instrument`` and
    :data:`IN_FAMILY_EFFECTS`. Raises ValueError for an instrument outside the family."""
    a = instrument.cable_asymmetry
    if instrument.jaw_mass_kg != 0.0 or a[1] != a[2] or instrument.cable_crossing_angle_rad != 0.0:
        raise ValueError("not an in-family instrument: use in_family_instrument() (jaw mass 0, "
                         "equal blade asymmetries, cables crossing the section along the shaft)")
    bias = instrument.hex10_residual_bias_n
    return {
        "pretension_total": instrument.pretension_total_n,
        "pulley_radius_pitch": instrument.pulley_radius_pitch_m,
        "pulley_radius_blade": instrument.pulley_radius_blade_m,
        "twist_gain": instrument.twist_tension_gain_per_rad2,
        "direction_tension": 0.0,                       # capstan off
        "asymmetry_pitch": a[0], "asymmetry_blade": a[1],
        "pitch_path_tension": 0.0,                      # pitch_path_mismatch off
        "distal_mass": instrument.distal_body_mass_kg + instrument.jaw_mass_kg,
        # the body's COM lies distal_body_com_m proximal of the pitch axis, the HEX10 origin
        # hex10_distance proximal of it: its distance along the HEX10 z axis (towards the tip)
        "distal_com_distance": (psm or PSM()).hex10_distance - instrument.distal_body_com_m,
        "cable_radius": instrument.cable_radius_in_section_m,
        "bias_fx": bias[0], "bias_fy": bias[1], "bias_fz": bias[2],
        "bias_tx": 0.0, "bias_ty": 0.0, "bias_tz": 0.0,  # the bench's tare offset is forces only
        "capstan_mu": 0.0,                              # capstan off
        "capstan_pitch_gain": 0.0, "capstan_roll_gain": 0.0,
        "pin_friction": 0.0,                            # pin_friction off
        "pitch_path_pretension": 0.0,                   # pitch_path_mismatch off
        **{n: 0.0 for n in (*CROSSTALK, *CROSSTALK_LATERAL)},  # hex10_crosstalk off
    }


def compare(prior: InternalForcePrior, truth: dict[str, float]) -> dict:
    """Per parameter: truth, fitted, relative error, and whether it is identifiable (not fixed,
    not in the report's ``not_identifiable``); ``failures``: the identifiable parameters off by
    more than :data:`RECOVERY_TOLERANCE` of the truth (an offset more than
    :data:`~psmforce.identification.prior_identifiability.OFFSET_RESOLUTION`:
    :func:`~psmforce.identification.prior_identifiability.recovered`)."""
    report = prior.info["identifiability"]
    rows, failures = {}, []
    for name, value in zip(NAMES, prior.params):
        true = truth[name]
        rel = abs(value / true - 1.0) if true != 0 else None
        status = ("fixed" if name in report["fixed"] else
                  "not identifiable" if name in report["not_identifiable"] else "identifiable")
        rows[name] = {"truth": true, "fitted": float(value), "relative_error": rel,
                      "standard_error": report["standard_errors"].get(name), "status": status}
        if status == "identifiable" and not recovered(name, float(value), true):
            failures.append(name)
    return {"parameters": rows, "failures": failures}


LOADED = ("Free", "Traction", "Palpation")


def recover(workdir, scale: float = 0.02, seed: int = 1, fixed: dict | None = None,
            conditions: tuple[str, ...] = LOADED) -> dict:
    """Simulate the automated protocol on the in-family bench into ``workdir`` (unless its
    metadata.json exists: then reuse it), fit the prior on the training split's ``conditions``
    (loaded trials make pairs slack) and :func:`compare` with the truth. ``fixed`` defaults to
    :data:`RECOVERY_FIXED`."""
    from psmforce.io.recording import list_recordings, read_recording
    from psmforce.sim import simulate

    instrument = in_family_instrument()
    meta = Path(workdir) / "metadata.json"
    if not meta.exists():
        simulate("automated", scale=scale, seed=seed, out=str(workdir), instrument=instrument,
                 effects=IN_FAMILY_EFFECTS)
    elif {k: json.loads(meta.read_text())[k] for k in ("scale", "seed", "effects", "instrument")} \
            != {"scale": scale, "seed": seed, "effects": IN_FAMILY_EFFECTS.to_dict(),
                "instrument": instrument.to_dict()}:
        raise ValueError(f"{workdir} holds another bench than the in-family one at scale "
                         f"{scale}, seed {seed}")
    frames = [read_recording(r.path) for r in list_recordings(Path(workdir))
              if r.split == "train" and r.condition in conditions]
    prior = InternalForcePrior.fit(frames, fixed=RECOVERY_FIXED if fixed is None else fixed)
    out = compare(prior, prior_truth(instrument))
    ident = prior.info["identifiability"]
    out.update({"scale": scale, "seed": seed, "conditions": list(conditions),
                "fixed": prior.info["fixed"], "converged": prior.converged,
                "n_samples": prior.info["n_samples"], "fit_time_s": prior.info["fit_time_s"],
                "identifiability": ident,
                "rest_level_n": {"truth": float(instrument.hex10_residual_bias_n[2]
                                                - instrument.pretension_total_n),
                                 "fitted": float(prior.params[NAMES.index("bias_fz")]
                                                 - prior.params[NAMES.index("pretension_total")])}})
    return out


# ---------------------------------------------------------------- the default bench
def default_bench_truth(instrument: InstrumentParams | None = None,
                        psm: PSM | None = None) -> dict[str, float | None]:
    """The prior's parameters (SI) that a bench with the default effects and ``instrument``
    (nominal by default) corresponds to, where it has a counterpart in the law; None where it
    has none. The default bench is outside the family (capstan, pin friction, hysteresis, disc
    friction and disturbance in the efforts, HEX10 cross-talk and drift, the jaws' mass off the
    shaft axis), so this is the bench's parameter value, not what an exact fit would return:
    ``direction_tension`` None (the capstan's direction-dependent friction has no single
    tension); ``asymmetry_blade`` the blade pairs' mean (the law ties them); ``distal_mass`` body
    plus jaws and ``distal_com_distance`` their COM along the HEX10 z axis at the straight wrist
    (the jaws' moves with the wrist angles); ``pitch_path_tension`` = cable stiffness x path
    mismatch (the bench adds it per blade cable, ``k e (1 - cos pitch)``), and
    ``pitch_path_pretension`` the same, its form as the blade cables' pretension; the
    asymmetries 0 under
    the quadratic pair law (``pair_law``, no linear term); the biases the residual tare offset
    (``hex10_residual_bias_n``; the moments' 0); ``crosstalk_fx`` ... ``crosstalk_tz`` the
    cross-talk matrix's entries of the axial force (``hex10_crosstalk``'s fz column) and
    ``crosstalk_<into>_from_<source>`` those of the lateral forces (its fx and fy columns; its
    moment columns have no counterpart);
    ``capstan_mu`` the idlers' friction exponent at the straight wrist without roll
    (``capstan_mu_wrap_distal``), ``capstan_pitch_gain`` and ``capstan_roll_gain`` its relative
    growth per rad of |wrist pitch| on the blade pairs (``capstan_wrap_pitch_gain``) and of
    |roll| (``twist_friction_gain_per_rad``), ``pin_friction`` the pulley pins'
    ``pin_friction_coefficient`` (the bench's friction state is driven by cable travel with a
    pre-sliding of ``presliding_length_m``). A law that holds ``pin_friction`` at 0 carries the
    pins in its capstan: :func:`effective_truth` then judges the capstan against their sum."""
    import numpy as np

    instrument = instrument or InstrumentParams()
    psm = psm or PSM()
    q = np.zeros((1, 7))
    q[0, 2] = 0.1
    d = psm.rotation(q, "hex10")[0][:, 2]
    cp = (psm.forward_kinematics(q, "cp")[0, :3, 3] - psm.forward_kinematics(q, "hex10")[0, :3, 3]
          ) @ d  # the control point's distance from the HEX10 origin along the shaft (m)
    m_b, m_j = instrument.distal_body_mass_kg, instrument.jaw_mass_kg
    l_b = psm.hex10_distance - instrument.distal_body_com_m
    l_j = float(cp) + instrument.jaw_com_m
    a = instrument.cable_asymmetry
    linear = instrument.pair_law == "linear"
    bias = instrument.hex10_residual_bias_n
    return {
        "pretension_total": instrument.pretension_total_n,
        "pulley_radius_pitch": instrument.pulley_radius_pitch_m,
        "pulley_radius_blade": instrument.pulley_radius_blade_m,
        "twist_gain": instrument.twist_tension_gain_per_rad2,
        "direction_tension": None,
        "asymmetry_pitch": a[0] if linear else 0.0,
        "asymmetry_blade": 0.5 * (a[1] + a[2]) if linear else 0.0,
        "pitch_path_tension": instrument.cable_stiffness_n_per_m * instrument.pitch_path_mismatch_m,
        "pitch_path_pretension": (instrument.cable_stiffness_n_per_m
                                  * instrument.pitch_path_mismatch_m),
        "distal_mass": m_b + m_j,
        "distal_com_distance": (m_b * l_b + m_j * l_j) / (m_b + m_j),
        "cable_radius": instrument.cable_radius_in_section_m,
        "bias_fx": bias[0], "bias_fy": bias[1], "bias_fz": bias[2],
        "bias_tx": 0.0, "bias_ty": 0.0, "bias_tz": 0.0,
        "capstan_mu": instrument.capstan_mu_wrap_distal,
        "capstan_pitch_gain": instrument.capstan_wrap_pitch_gain,
        "capstan_roll_gain": instrument.twist_friction_gain_per_rad,
        "pin_friction": instrument.pin_friction_coefficient,
        **{n: instrument.hex10_crosstalk[row][col]
           for n, (row, col) in CROSSTALK_ENTRIES.items()},
    }


PATH_FORMS = ("pitch_path_tension", "pitch_path_pretension")
"""The blade cables' one path tension in the law's two forms (:func:`default_bench_truth` gives
both the bench's value): a law at the bench's parameters carries it in one."""


def truth_law(truth: dict, inputs: str, crosstalk=None) -> InternalForcePrior:
    """The law at the bench's own parameters (``truth``, :func:`default_bench_truth`; those
    without a counterpart at 0) reading ``inputs``, the blade cables' path tension in the form
    the reading keeps (:data:`PATH_FORMS`; the other, which the reading holds, at 0), and the
    sensor's lateral cross-talk only where a fit with ``crosstalk`` (as
    :meth:`~psmforce.identification.prior.InternalForcePrior.fit`'s) has it: a law without it
    is projected from the bench's law without it."""
    import numpy as np

    from psmforce.identification.prior import held_by_reading
    held = {n: 0.0 for n in (*PATH_FORMS, *CROSSTALK_LATERAL)
            if n in held_by_reading(inputs, crosstalk)}
    return InternalForcePrior(params=np.array([held.get(n, truth.get(n) or 0.0) for n in NAMES]),
                              info={"inputs": inputs})


TRUTH_LAW = "the bench's parameters, the path tension once, in the reading's form (truth_law)"
"""What a run's ``truth_law_test_loaded_internal_metrics`` scored; a run without the record
scored a law carrying the blade cables' path tension in both forms."""


def _truth_law_metrics(truth: dict, score) -> dict:
    """``score`` (held-out metrics of a prior) of the law at the bench's own parameters
    (:func:`truth_law`), read from the motor efforts and from the load path: what each reading
    leaves when no fit is to blame."""
    return {inputs: score(truth_law(truth, inputs)) for inputs in ("efforts", "load_path")}



def bench_capstan_over(frames, instrument: InstrumentParams) -> float:
    """The bench's friction exponent at the wrist (the idlers' capstan,
    ``sim.cables.capstan_exponents``, plus the pulley pins' coefficient; default effects)
    averaged over the pairs and the samples of ``frames`` (recordings): the one constant the
    law's ``capstan_mu`` stands for where the bench's grows with |wrist pitch| and |roll|
    (:func:`default_bench_truth` gives its value at the straight wrist)."""
    import numpy as np

    from psmforce.io.recording import JOINT_POSITIONS
    from psmforce.sim.cables import capstan_exponents
    q = np.concatenate([f[list(JOINT_POSITIONS)].to_numpy(dtype=float) for f in frames])
    mu = capstan_exponents(q[:, 3], q[:, 4], instrument, Effects())[0]
    return float(np.broadcast_to(mu, (len(q), 3)).mean()) + instrument.pin_friction_coefficient


def crosstalk_of_rest_level(instrument: InstrumentParams) -> dict[str, float]:
    """What the HEX10's cross-talk (``hex10_crosstalk``, reading = X wrench + offset) makes of
    the pretension's axial force ``-pretension_total`` (N, straight wrist, no roll) in the other
    channels (N, Nm): a constant the law carries in its biases where it holds its cross-talk
    terms (the efforts reading) (the bench's parameters, for the comparison)."""
    rest = -instrument.pretension_total_n
    x = instrument.hex10_crosstalk
    return {f"bias_{c}": float(x[k][2] * rest) for k, c in enumerate(("fx", "fy", "fz", "tx",
                                                                      "ty", "tz")) if k != 2}


CAPSTAN = ("capstan_mu", "capstan_pitch_gain", "capstan_roll_gain")
"""The law's capstan terms: where the pins are held at 0 they carry the pins' friction too
(:func:`effective_truth`)."""


def pins_held(rows: dict) -> bool:
    """Whether a fit held the pins' friction at 0 where the bench has some, so that its capstan
    carries theirs (``rows``: :func:`compare_selection`'s parameters)."""
    pins = rows.get("pin_friction")
    return bool(pins is not None and pins["status"] == "fixed" and pins["fitted"] == 0.0
                and pins["truth"])


def projected_truth(truth: dict, rows: dict, recordings, inputs: str, compliance=None,
                    psm: PSM | None = None, crosstalk=None) -> dict[str, float]:
    """The law at the bench's parameters (:func:`truth_law` of ``truth``) projected onto the
    law as a fit holds it, on that fit's own training ``recordings`` and reading ``inputs``
    (with the load path, the ``compliance`` it sagged the wrist with): the law refitted to the
    bench law's output, what the fit held (``rows``' *fixed*) held at the same values, the rest
    free from the fitted values (:meth:`~psmforce.identification.prior.InternalForcePrior.fit`
    ``reference``). Name -> SI value: what a parameter's truth is in the held law on these
    recordings, where a first-order rule (:func:`effective_truth`) only approximates it.
    ``crosstalk``: the fit's (:func:`truth_law`); a term the rows do not have (a run before it)
    is held at 0."""
    reference = truth_law(truth, inputs, crosstalk)
    fixed = {n: row["fitted"] for n, row in rows.items() if row["status"] == "fixed"}
    fixed.update({n: 0.0 for n in NAMES if n not in rows})
    start = {n: row["fitted"] for n, row in rows.items() if row["status"] != "fixed"}
    fit = InternalForcePrior.fit(recordings, psm=psm, fixed=fixed, initial=start, report=False,
                                 inputs=inputs, crosstalk="full", compliance=compliance,
                                 reference=reference)
    return dict(zip(NAMES, map(float, fit.params)))


def needs_projection(rows: dict) -> bool:
    """Whether a fit's capstan carries the pins' friction and is judged (:func:`pins_held`,
    a capstan term identified): where :func:`projected_truth` gives its truth as held."""
    return pins_held(rows) and any(rows.get(n, {}).get("status") == "identified"
                                   for n in CAPSTAN)


def with_projection(run: dict, truth: dict, recordings, compliance=None) -> dict:
    """``run`` (:func:`compare_selection`'s result with its ``inputs``) with, where it
    :func:`needs_projection`, every parameter's ``projected_truth`` on the fit's training
    ``recordings`` (with the load path, the ``compliance`` the fit sagged the wrist with) and
    its misses judged again (:func:`judge`)."""
    rows = run["parameters"]
    if needs_projection(rows):
        projected = projected_truth(truth, rows, recordings, run["inputs"], compliance,
                                    crosstalk=run.get("crosstalk"))
        for name, row in rows.items():
            row["projected_truth"] = projected[name]
        run.update(judge(rows))
    return run


def effective_truth(rows: dict) -> dict[str, float]:
    """The truth a parameter has in the law as fitted, where it differs from the bench's value.
    A bias: a cross-talk term held off its truth (``crosstalk_c`` fixed; the efforts reading
    holds them all at 0) leaves ``(truth - held) x`` the rest axial force (``-pretension_total``,
    the bench's) in channel ``c``, a constant only ``bias_c`` can carry
    (:func:`crosstalk_of_rest_level` with nothing held). The capstan: with ``pin_friction`` held
    at 0 the pins add ``c S z`` to a pair's differential, which is the capstan's ``D + mu S z``
    to first order, so the capstan carries both, ``capstan_mu`` their sum and its growth terms
    the idlers' scaled by the idlers' share (the pins' friction does not grow with the
    configuration; ``tests/experiments/test_prior_recovery.py``); where the rows record the
    bench's law projected onto the held law (``projected_truth``, :func:`projected_truth`), the
    capstan's three terms are judged against that instead of the first-order sum and share. The
    blade cables' path tension: its form a reading holds at 0 (``pitch_path_tension`` in the
    load path, ``pitch_path_pretension`` in the efforts) has the truth 0, the other carries it.
    ``rows``: :func:`compare_selection`'s parameters (truth, fitted, status)."""
    rest = -rows["pretension_total"]["truth"]
    out = {}
    for name, other in (PATH_FORMS, PATH_FORMS[::-1]):
        row, alt = rows.get(name), rows.get(other)
        if (row is not None and alt is not None and row["status"] == "fixed"
                and row["fitted"] == 0.0 and row["truth"]
                and not (alt["status"] == "fixed" and alt["fitted"] == 0.0)):
            out[name] = 0.0  # held at 0 by the reading: the other form carries the path
    pins, capstan = rows.get("pin_friction"), rows.get("capstan_mu")
    if pins_held(rows) and all("projected_truth" in rows.get(n, {}) for n in CAPSTAN):
        out.update({n: rows[n]["projected_truth"] for n in CAPSTAN})
    elif pins_held(rows) and capstan is not None and capstan["truth"] is not None:
        wrist = capstan["truth"] + pins["truth"]
        out["capstan_mu"] = wrist
        for name in ("capstan_pitch_gain", "capstan_roll_gain"):
            if rows.get(name, {}).get("truth") is not None:
                out[name] = rows[name]["truth"] * capstan["truth"] / wrist
    for name in CROSSTALK:
        row, bias = rows.get(name), "bias_" + name.removeprefix("crosstalk_")
        if (row is None or row["status"] != "fixed" or row["truth"] is None
                or rows.get(bias, {}).get("truth") is None):
            continue
        shift = (row["truth"] - row["fitted"]) * rest
        if shift != 0.0:
            out[bias] = rows[bias]["truth"] + shift
    return out


def judge(rows: dict) -> dict:
    """``misses`` and ``uncompared`` of :func:`compare_selection`'s rows (adding each shifted
    bias's ``effective_truth``, :func:`effective_truth`): an identified parameter more than
    :data:`RECOVERY_TOLERANCE` off its truth as the law holds it, or with a truth of 0, an offset
    more than its resolution off (:func:`~psmforce.identification.prior_identifiability.
    recovered`); ``uncompared``: identified ones without a truth. The same rule for a fresh fit
    and for a stored one (``studies/prior_recovery.py --rescore``)."""
    shifted = effective_truth(rows)
    misses, uncompared = [], []
    for name, row in rows.items():
        row.pop("effective_truth", None)
        if name in shifted:
            row["effective_truth"] = shifted[name]
        if row["status"] != "identified":
            continue
        true = row.get("effective_truth", row["truth"])
        if true is None:
            uncompared.append(name)
        elif not recovered(name, float(row["fitted"]), true):
            misses.append(name)
    return {"misses": misses, "uncompared": uncompared,
            "recovery_tolerance": RECOVERY_TOLERANCE, "offset_resolution": OFFSET_RESOLUTION,
            "truth_as_held": "a bias is judged against its effective truth where a cross-talk "
                             "term is held off the bench's, the capstan where the pins are held "
                             "at 0 (against the bench's law projected onto the held law where "
                             "the run records it), a form of the path tension the reading holds "
                             "at 0 (effective_truth)"}


def rescore(result: dict, command: str) -> dict:
    """``result`` (a study's JSON: ``runs`` of :func:`compare_selection` rows) with every run's
    misses judged again by :func:`judge` (the fits untouched), and ``rescored``: ``command`` and
    which runs' misses changed (old and new)."""
    changed = []
    for k, run in enumerate(result["runs"]):
        before = (list(run["misses"]), list(run["uncompared"]))
        run.update(judge(run["parameters"]))
        if (run["misses"], run["uncompared"]) != before:
            changed.append({"run": k, "misses_before": before[0], "misses": run["misses"]})
    result["rescored"] = {"command": command, "rule": "prior_recovery.judge", "changed": changed}
    return result


def compare_selection(prior: InternalForcePrior, truth: dict) -> dict:
    """Per parameter of a :func:`~psmforce.identification.prior_selection.fit_identified` prior:
    truth (None: no counterpart), fitted, relative error (None where the truth is None or 0),
    ``status`` ("identified": free and not listed; "fixed": held at its design value;
    "free, not identified": listed on the final fit), ``at_bound`` (the fit's
    ``bounds_hit``, the rule of :func:`~psmforce.identification.prior_law.at_bound`) and the
    all-free fit's value; ``misses``, ``uncompared`` and the tolerances: :func:`judge`."""
    sel = prior.info["selection"]
    first = sel["rounds"][0]["parameters"] if sel["rounds"] else {}
    rows = {}
    for name, value in zip(NAMES, prior.params):
        true = truth.get(name)
        rel = abs(value / true - 1.0) if true not in (None, 0) else None
        status = ("fixed" if name in sel["fixed"] else
                  "identified" if name in sel["identified"] else "free, not identified")
        rows[name] = {"truth": true, "fitted": float(value), "relative_error": rel,
                      "status": status, "at_bound": name in prior.info["bounds_hit"],
                      "all_free_fit": first.get(name),
                      "reason": (sel["fixed"][name]["reason"] if name in sel["fixed"] else
                                 prior.info["identifiability"]["not_identifiable"].get(name))}
    return {"parameters": rows, **judge(rows)}


def recover_default(workdir, seed: int, scale: float = 1.0,
                    instrument: InstrumentParams | None = None, load_path: bool = False,
                    crosstalk=None) -> dict:
    """``psmforce simulate --seed SEED [--scale SCALE]`` (default effects; ``instrument``
    nominal unless given: a ``pair_law`` variant, a drawn tool) into ``workdir`` unless its
    metadata.json exists, then ``psmforce fit-prior`` (:func:`~psmforce.identification.
    prior_report.fit_prior_cli`: Free trials, what the data cannot identify held at design
    values) and :func:`compare_selection` with :func:`default_bench_truth`. ``load_path``:
    ``fit-prior --use-loaded --load-path`` (every training trial, the cables read from the known
    tip force: :mod:`psmforce.identification.load_path`). Both are scored on the held-out
    Free trials and, with their known force, on the held-out loaded trials. ``crosstalk``:
    ``fit-prior --crosstalk`` (the fit's, None: as the reading does), recorded in the run."""
    from psmforce.identification.prior_report import fit_prior_cli
    from psmforce.sim import simulate

    instrument = instrument or InstrumentParams()
    workdir = Path(workdir)
    meta = workdir / "data" / "metadata.json"
    if not meta.exists():
        simulate("automated", scale=scale, seed=seed, out=str(workdir / "data"),
                 instrument=instrument)
    elif {k: json.loads(meta.read_text())[k] for k in ("scale", "seed", "instrument")} != {
            "scale": scale, "seed": seed, "instrument": instrument.to_dict()}:
        raise ValueError(f"{workdir} holds another bench than scale {scale}, seed {seed}")
    inputs = "load_path" if load_path else "efforts"
    report = fit_prior_cli(workdir / "data", workdir / "prior.json", identify=True,
                           use_loaded=load_path, inputs=inputs, crosstalk=crosstalk)
    prior = InternalForcePrior.load(workdir / "prior.json")
    truth = default_bench_truth(instrument)
    out = {**compare_selection(prior, truth), "inputs": inputs,
           **({"crosstalk": crosstalk} if crosstalk is not None else {})}
    sel = prior.info["selection"]
    # the all-free fit (the first round) scored on the same held-out trials: the curve fit
    import numpy as np

    from psmforce.identification.prior import channel_metrics
    from psmforce.io.recording import HEX10, list_recordings, read_recording
    from psmforce.identification.prior import internal_wrench_target
    test = [read_recording(r.path) for r in list_recordings(workdir / "data")
            if r.split == "test" and r.condition == "Free"]
    loaded = [read_recording(r.path) for r in list_recordings(workdir / "data")
              if r.split == "test" and r.condition != "Free"]
    first = InternalForcePrior(params=np.array([sel["rounds"][0]["parameters"][n] for n in NAMES]),
                               info={"inputs": inputs})
    all_free_metrics = channel_metrics(
        np.concatenate([f[list(HEX10)].to_numpy(dtype=float) for f in test]),
        np.concatenate([first.predict(f) for f in test])) if test else None

    def internal_metrics(model):  # the held-out loaded trials' internal wrench, force known
        if not loaded:
            return None
        targets = [internal_wrench_target(f) for f in loaded]
        return channel_metrics(np.concatenate([y for y, _ in targets]),
                               np.concatenate([model.predict(f) for f in loaded]),
                               np.concatenate([m for _, m in targets]))
    train = [read_recording(r.path) for r in list_recordings(workdir / "data")
             if r.split == "train" and r.condition in report["conditions"]]
    with_projection(out, truth, train, prior.wrist_compliance)
    out.update({
        "seed": seed, "scale": scale, "pair_law": instrument.pair_law, "inputs": inputs,
        **({"sag": sel["sag"]} if "sag" in sel else {}),
        "capstan_mu_over_training": bench_capstan_over(train, instrument),
        "conditions": report["conditions"],
        "test_loaded_internal_metrics": internal_metrics(prior),
        "all_free_test_loaded_internal_metrics": internal_metrics(first),
        "truth_law_test_loaded_internal_metrics": _truth_law_metrics(truth, internal_metrics),
        "truth_law": TRUTH_LAW,
        "verdict": report["verdict"], "converged": report["converged"],
        "fit_time_s": report["fit_time_s"], "n_samples": prior.info["n_samples"],
        "design": sel["design"], "rounds": sel["rounds"],
        "test_free_metrics": report.get("test_free_metrics"),
        "all_free_test_free_metrics": all_free_metrics,
        "crosstalk_of_rest_level": crosstalk_of_rest_level(instrument),
        "all_free_not_identifiable": sorted(sel["rounds"][0]["not_identifiable"]),
        "targets_not_met": report.get("targets_not_met"),
        "identifiability": prior.info["identifiability"]})
    return out
