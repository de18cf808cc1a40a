"""The internal-force prior as an identification: what the data cannot pin down is fixed at its
design value, named, and the rest refitted (docs/identification.md section 2, "Which
parameters are fitted").

:func:`fit_identified` fits the prior (:meth:`InternalForcePrior.fit`) with every parameter free,
reads the identifiability report (:func:`~psmforce.identification.prior_identifiability.
identifiability`: at a bound, correlated beyond 0.99, too few slack samples, errors in variables,
sandwich standard errors) extended by a jackknife over groups of whole trials
(:func:`trial_jackknife`, :func:`~psmforce.identification.prior_identifiability.
add_trial_spread`: the spread of refits that leave one group of trials out, which sees the
coloured effort disturbance, the stuck discs and the sensor drift that the white-noise standard
errors do not), fixes the listed parameters at their values in :data:`DESIGN` and refits, until
the report lists nothing or :data:`MAX_ROUNDS` rounds have run. Each round fixes one tier of
reasons (:func:`_tier`): first the structural ones (at a bound, too few slack samples,
correlation beyond 0.99, errors in variables), and only on a fit without them the statistical
ones (standard errors, jackknife), then those only tied to a listed parameter: a degenerate fit
(a pretension at its bound) makes every other estimate wander, and fixing the pretension may
free bias_fz.

A designed experiment (known weights hung in a few orientations, every mass in every one) adds a
second jackknife (``pose_labels``): each orientation left out with every mass hung in it. The trial
jackknife removes whole masses, so every refit keeps every orientation, and a term that one
orientation alone pins down looks as precise as any; leaving that orientation out moves it. It runs
once a round has nothing else to hold (its refits cost one per orientation), with the same rule (3
standard errors within the needed precision), and what it lists is held as the trial jackknife's is.
In a paired design (each orientation hung beside its opposite) the unit can be the pair
(``pose_unit="sign_pair"``): one orientation left out alone leaves its opposite unbalanced, which
moves the terms the pair's difference cancels. Given how far each design value may be off
(``design_tolerance``, for example :data:`DESIGN_TOLERANCE`), every round also lists a free
parameter that the held values, each off by that much, would move beyond its needed precision (to
first order: "rests on held design values",
:func:`~psmforce.identification.prior_identifiability.held_value_shifts`): no spread of the data
sees the bias a held value puts on the parameters correlated with it. The final fit's
``info["selection"]`` holds each round, the fixed parameters with the reason and the value they had
when they were listed, and ``info["verdict"]`` the one line that names the identified, the fixed and
the at-bound parameters (:func:`verdict_line`; printed by ``psmforce fit-prior``).

What is held among the imprecise is a rule (``hold_rule``, :data:`HOLD_RULES`). ``"imprecise"``
holds every parameter listed, the 10 % precision rule included. ``"unresolved"`` keeps free a
parameter listed for its precision alone (standard errors, a jackknife, the held values' shift:
never a structural reason) whose design value may be off the instrument's (a tolerance in
:data:`DESIGN_TOLERANCE`, or the user's ``design_tolerance``; a value known exactly is held) and
which the data reject: farther from it than 3 of its largest standard errors plus the held
values' shift (:func:`design_rejected`). Held, such a parameter would sit at a value the data
place beyond the estimate's own uncertainty, the worse of the two; and every parameter
correlated with it would take its error, so a round that holds it can list what it did not
list before. It is named ``estimated`` with that uncertainty (the verdict's own list), not
identified. ``"least-uncertain"`` keeps the better known of the two values instead: such a
parameter is held only where its design value's tolerance is no larger than the data's
uncertainty about the estimate (3 of its largest standard errors plus the held values' shift,
:func:`data_uncertainty`), else kept free and named estimated, whether or not the data reject
the design value. A design value known exactly is held. Where the tool-to-tool spread is wide
and the data narrow, as a sensor's cross-talk read across the clenches (below), the estimate is
the better value even when it lies within its own uncertainty of the design's.

The jaws clenched on each other (``clenched_lateral``, through the load path). The load path
leaves clenched samples out: the grip is internal to the jaws, no tip force shows it, and it
loads the blade pairs, so the axial force and the moments there are not the law's. It puts no
lateral force through the section, though (the cables cross it along the shaft), and it moves
the axial reading by several newtons: there the lateral channels read the distal weight and the
sensor's cross-talk of that axial reading, which the law has. Counted, they give each lateral
channel's cross-talk a span of the axial reading that free space alone does not have (there the
axial force stays near the pretension's rest level, and the offset and the cross-talk are
correlated above 0.99); left out, a cross-talk the clenches would pin down is held at its
design value 0 and the offset takes its share of the rest level, which a loaded cable then
carries into the lateral estimate in contact. The converse holds as well: a lateral offset
held at its design value 0 (listed, for example, for its correlation with the axial offset,
which the cross-talk reads the axial force less) leaves its share of the rest level to the
cross-talk. A sensor offset has no design value (the tare leaves a residual, this mount's), so
``free_lateral_offsets`` never holds ``bias_fx`` and ``bias_fy``: listed, they stay free and
are named not identifiable, and the slope beside them is judged on its own.

Read through the load path, the tip force's moments are taken where the wrist sags, and the sag
depends on the law's own pretension, radii and friction (:mod:`~psmforce.identification.
load_path`). The rounds sag it with the design's values until they have nothing left to hold;
then the selection goes on with the sag the fit's own values give (:func:`fitted_compliance`),
round after round as before, until the sag a fit took and the one it gives agree
(:data:`SAG_TOLERANCE`, at most :data:`SAG_PASSES` passes): a fixed point of the fit and its sag,
so the parameters it reports, and what it holds, are those of the sag it took.
``info["selection"]["sag"]`` records each pass, and the verdict names a sag that did not
converge.

Cost: one fit and :data:`JACKKNIFE_GROUPS` warm-started refits per round (2-3 rounds on the
default bench), and one refit per orientation in each round that the orientations' jackknife
judges; with the load path, a round or more per sag pass (1-2 passes on the ATI-free
study's recordings).

Size: one procedure (the rounds, the two jackknifes, the sag's fixed point) with the design
values and their tolerances it holds and checks against, kept together because each round's
rule reads all of them; the report it reads lives in :mod:`.prior_identifiability`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import (HELD_BY_READING_REASON, held_by_reading,
                                           InternalForcePrior)
from psmforce.identification.prior_identifiability import (JACKKNIFE_OVER, RECOVERY_TOLERANCE,
                                                        add_trial_spread)
from psmforce.identification.prior_law import CROSSTALK_LATERAL, NAMES, at_bound
from psmforce.io.recording import read_recording

DESIGN = {
    "pretension_total": 6.0,        # N: the tensioning specification (docs/simulator.md s. 10)
    "pulley_radius_pitch": 2.0e-3,  # m: datasheet geometry (s. 6, 10)
    "pulley_radius_blade": 1.5e-3,  # m: datasheet geometry
    "twist_gain": 0.03,             # 1/rad^2: nominal (+19 % pretension at 2.5 rad roll, s. 10)
    "direction_tension": 0.0,       # N: no friction by design
    "asymmetry_pitch": 0.30,        # 1: nominal pair asymmetry (s. 10)
    "asymmetry_blade": 0.275,       # 1: nominal blade pairs' (0.25, 0.30), tied by the law
    "pitch_path_tension": 0.896,    # N: cable stiffness 2.8e5 N/m x path mismatch 3.2 um (s. 10)
    "distal_mass": 5.5e-3,          # kg: distal body 4 g + jaws 1.5 g (s. 7, 10)
    "distal_com_distance": 0.0265,  # m: from the HEX10 along z, straight wrist: body 4 g at
    # 25 - 4 = 21 mm, jaws 1.5 g 7 mm beyond the control point (34.1 mm):
    # (4 x 21 + 1.5 x 41.1) / 5.5
    "cable_radius": 1.2e-3,         # m: cables cross the bore at 1.2 mm (s. 7)
    "bias_fx": 0.0, "bias_fy": 0.0, "bias_fz": 0.0,     # N: the sensor is tared
    "bias_tx": 0.0, "bias_ty": 0.0, "bias_tz": 0.0,     # Nm: the sensor is tared
    "capstan_mu": 0.0,              # 1: no friction by design
    # 1/rad: the exponent's growth with the configuration: the blade cables' wrap of about
    # 2 rad at the straight wrist grows by |pitch| (geometry, s. 7 and 10); roll twist (assumed)
    "capstan_pitch_gain": 0.5, "capstan_roll_gain": 0.15,
    "crosstalk_fx": 0.0, "crosstalk_fy": 0.0,  # 1: the sensor's calibration decouples it
    "crosstalk_tx": 0.0, "crosstalk_ty": 0.0, "crosstalk_tz": 0.0,  # m: likewise
    "pin_friction": 0.0,            # 1: no friction by design (held, the capstan carries it)
    "pitch_path_pretension": 0.896,  # N: pitch_path_tension's, as the blade cables' pretension
    **dict.fromkeys(CROSSTALK_LATERAL, 0.0),  # 1 and m: the sensor's calibration decouples it
}
"""The value a parameter is held at when the data cannot pin it down: the instrument's design
(nominal) values as docs/simulator.md states them, read as a datasheet (SI, :data:`NAMES`). They
are the nominal tool's, so on a bench simulated with the nominal tool (``psmforce simulate``
without ``--tool-seed``) the instrument parameters' design values equal the bench's truth by
construction, and the biases' design value 0 is not their truth (the tare leaves an offset);
``fixed`` in the report says which were held. A user holds their own instrument's values
(``fit_identified(design=...)``)."""

DESIGN_TOLERANCE = {
    # twice the tool-to-tool spread the bench draws instruments with (InstrumentParams.sample,
    # docs/simulator.md section 10: lognormal 0.15 pretension, 0.08 radii, 0.3 twist and path,
    # 0.1 asymmetry, cross-talk 0.006 and 0.3 mm), where the design value is the nominal one
    "pretension_total": 1.8, "pulley_radius_pitch": 3.2e-4, "pulley_radius_blade": 2.4e-4,
    "twist_gain": 0.018, "asymmetry_pitch": 0.2, "asymmetry_blade": 0.2,
    "pitch_path_tension": 0.54, "pitch_path_pretension": 0.54,
    # a friction held at 0 ("none by design"): the real EndoWrist's friction-load slope is
    # 0.27-0.44 over its seven folders (docs/simulator.md section 12b), sinh(mu) for a capstan
    "capstan_mu": 0.45,
    **dict.fromkeys(("crosstalk_fx", "crosstalk_fy"), 0.012),
    **dict.fromkeys(("crosstalk_tx", "crosstalk_ty", "crosstalk_tz"), 6e-4),
    **{n: 0.012 if n.split("_")[1] in ("fx", "fy", "fz") else 6e-4 for n in CROSSTALK_LATERAL},
    # the tare's residual offset (the bench's 0.05 N per axis, twice)
    "bias_fx": 0.1, "bias_fy": 0.1, "bias_fz": 0.1,
}
"""How far a design value in :data:`DESIGN` may be off an instrument's truth (SI): what the
report's held-value check (:func:`~psmforce.identification.prior_identifiability.
identifiability`, "rests on held design values") moves the held values by, when asked
(``fit_identified(design_tolerance=DESIGN_TOLERANCE)``). A parameter not
listed is not moved (design values known exactly on the bench: the distal mass and its
distance, the cable radius, the capstan's configuration gains, the pins, the moment offsets,
none of which is drawn per tool). A user holding their own values gives their own
(``fit_identified(design_tolerance=...)``)."""

MAX_ROUNDS = 6
"""Fit - report - fix rounds at most; the report lists what is still unidentified after them."""
JACKKNIFE_GROUPS = 4
"""Groups of whole trials the jackknife leaves out one at a time (trial k goes to group
k mod 4, so every group holds every condition)."""
LATERAL_OFFSETS = ("bias_fx", "bias_fy")
"""The HEX10's lateral force offsets: each the intercept of its channel's line in the axial
reading, whose slope is the cross-talk (``fit_identified(free_lateral_offsets=True)``)."""
HOLD_RULES = ("imprecise", "unresolved", "least-uncertain")
"""What :func:`fit_identified` (``hold_rule``) holds at its design value among the parameters listed
for their precision alone: ``"imprecise"`` every one (the 10 % rule; every figure written before
the choice existed); ``"unresolved"`` only those whose design value the data do not reject
(:func:`design_rejected`); ``"least-uncertain"`` only those whose design value is known at
least as well as the data know the estimate (its tolerance against :func:`data_uncertainty`);
the others kept free and named estimated (module docstring)."""


def design_rejected(report: dict, params, design: dict,
                    uncertain=tuple(DESIGN_TOLERANCE)) -> dict[str, float]:
    """Free parameter -> its uncertainty (SI) for each one in ``uncertain`` (whose design value
    may be off the instrument's: by default those :data:`DESIGN_TOLERANCE` lists; one known
    exactly is never rejected) whose distance from its value in ``design`` exceeds it; the
    uncertainty is 3 times the largest of its standard errors in the identifiability ``report``
    (sandwich, every jackknife added) plus the shift the held values' tolerance gives it
    (``held_value_shift``: a bias, added, not a spread)."""
    out = {}
    for name in (n for n in report["standard_errors"] if n in uncertain):
        uncertainty = data_uncertainty(report, name)
        if abs(float(params[NAMES.index(name)]) - design[name]) > uncertainty:
            out[name] = uncertainty
    return out


def data_uncertainty(report: dict, name: str) -> float:
    """How well the data know free parameter ``name`` (SI): 3 times the largest of its
    standard errors in the identifiability ``report`` (sandwich, every jackknife added) plus the
    shift the held values' tolerance gives it (``held_value_shift``: a bias, added)."""
    kinds = [se for key, se in report.items() if key.endswith("standard_errors")]
    return float(3 * max(kind.get(name, 0.0) for kind in kinds)
                 + report.get("held_value_shift", {}).get(name, 0.0))


def _holding(report: dict, params, design: dict, hold_rule: str,
             tolerance: dict, free_offsets=()) -> tuple[dict, dict]:
    """(what ``report`` lists that ``hold_rule`` holds: name -> reason, what it keeps free as
    estimated: name -> uncertainty); the design values that may be off: those ``tolerance``
    gives a tolerance above 0, else those :data:`DESIGN_TOLERANCE` lists; ``free_offsets``
    are never held (listed, they stay free and not identified)."""
    listed = {n: why for n, why in report["not_identifiable"].items() if n not in free_offsets}
    if hold_rule == "imprecise":
        return dict(listed), {}
    tolerances = {n: t for n, t in tolerance.items() if t > 0} if tolerance else DESIGN_TOLERANCE
    statistical = [n for n, why in listed.items() if _tier(why) == 1]
    if hold_rule == "least-uncertain":
        own = {n: data_uncertainty(report, n) for n in statistical}
        estimated = {n: u for n, u in own.items() if tolerances.get(n, 0.0) > u}
    else:
        rejected = design_rejected(report, params, design, list(tolerances))
        estimated = {n: rejected[n] for n in statistical if n in rejected}
    return {n: why for n, why in listed.items() if n not in estimated}, estimated


def _frames(recordings) -> list:
    return [read_recording(r) if isinstance(r, (str, Path)) else r for r in recordings]


def trial_jackknife(frames, prior: InternalForcePrior, fixed: dict[str, float],
                    groups: int = JACKKNIFE_GROUPS, psm=None, max_iter: int = 500,
                    inputs: str = "efforts", labels=None,
                    compliance=None) -> dict[str, float] | None:
    """Delete-a-group jackknife standard error of each free parameter over ``groups`` groups of
    whole trials (trial k in group k mod ``groups``, or in group ``labels[k]``; a label None
    keeps that trial in every refit): refit without
    each group, warm-started at ``prior``'s parameters, ``se^2 = (G - 1) / G sum_g (p_g -
    mean p)^2`` (SI units). None when there are fewer trials than groups. ``fixed``: every
    parameter the fit of ``prior`` held, the reading's included; the refits hold exactly these.
    ``compliance``: the load path's sag, as the fit of ``prior`` took it.

    ``labels`` (one int in [0, groups) per trial) is for a designed experiment whose trials are
    not exchangeable: k mod G on holds ordered by pose removes the same poses in every
    replicate, so a group's refit measures a design with poses missing, not the noise
    (:func:`design_groups`)."""
    if len(frames) < groups or groups < 2:
        return None
    labels = [k % groups for k in range(len(frames))] if labels is None else list(labels)
    if len(labels) != len(frames) or not all(
            g is None or (isinstance(g, int) and not isinstance(g, bool) and 0 <= g < groups)
            for g in labels):
        raise IdentificationInputError(f"jackknife labels must be {len(frames)} integers in "
                                       f"[0, {groups}) or None, one per recording")
    start = {n: float(x) for n, x in zip(NAMES, prior.params) if n not in fixed}
    refits = []
    for g in range(groups):
        kept = [f for f, label in zip(frames, labels) if label != g]
        refits.append(InternalForcePrior.fit(
            kept, psm=psm, fixed=fixed, initial=start, report=False, max_iter=max_iter,
            inputs=inputs, crosstalk="full", compliance=compliance,
            clenched_lateral=prior.info.get("clenched_lateral", False)).params)
    p = np.array(refits)
    se = np.sqrt((groups - 1) / groups * np.sum((p - p.mean(axis=0)) ** 2, axis=0))
    return {n: float(se[i]) for i, n in enumerate(NAMES) if n not in fixed}


def design_groups(replicates, groups: int = JACKKNIFE_GROUPS) -> list[int]:
    """Jackknife labels (:func:`trial_jackknife`) for trials of which some are replicates of a
    design: ``replicates[k]`` None for an ordinary trial (in group k' mod ``groups``, k' its rank
    among those), else the replicate it belongs to (any hashable, a known load's mass, say: every
    mass hangs in every pose), the replicates' groups taken in order of first appearance, mod
    ``groups``. A group then removes whole replicates, never one pose from all of them."""
    order: dict = {}
    labels, plain = [], 0
    for r in replicates:
        if r is None:
            labels.append(plain % groups)
            plain += 1
        else:
            labels.append(order.setdefault(r, len(order)) % groups)
    return labels


def fitted_compliance(prior: InternalForcePrior, design: dict | None = None):
    """The wrist's sag (:class:`~psmforce.identification.load_path.WristCompliance`) a fit's
    own values give: its pretension, radii, asymmetries and friction; a parameter at its bound
    (:func:`~psmforce.identification.prior_law.at_bound`) takes its value in ``design``
    (default :data:`DESIGN`), as the selection would hold it."""
    from psmforce.identification.load_path import WristCompliance
    design = {**DESIGN, **(design or {})}
    bound = at_bound(prior.params)
    return WristCompliance.from_law({n: design[n] if bound[i] else float(prior.params[i])
                                     for i, n in enumerate(NAMES)})


def _sag_change(old, new) -> float:
    """The largest relative change between two compliances' fields (a friction term's change
    over 0.01 at least: the terms are 0 by design)."""
    from dataclasses import fields
    change = 0.0
    for f in fields(old):
        a, b = getattr(old, f.name), getattr(new, f.name)
        floor = SAG_FRICTION_FLOOR if f.name in _SAG_FRICTION else 0.0
        change = max(change, abs(b - a) / max(abs(a), abs(b), floor, 1e-300))
    return float(change)


SAG_PASSES = 3
"""Refits at most with the sag the previous fit's own values give (:func:`fit_identified`
with the load path), until those values change the sag by under :data:`SAG_TOLERANCE`."""
SAG_TOLERANCE = 0.01
"""Largest relative change of the sag's terms (:func:`_sag_change`) at which the load path's
fit and the sag it took agree."""
SAG_FRICTION_FLOOR = 0.01
_SAG_FRICTION = ("capstan_mu", "capstan_pitch_gain", "capstan_roll_gain", "pin_friction")


def fit_identified(recordings, *, psm=None, provenance=None, design: dict | None = None,
                   groups: int = JACKKNIFE_GROUPS, max_rounds: int = MAX_ROUNDS,
                   max_iter: int = 500, inputs: str = "efforts",
                   jackknife_labels=None, crosstalk: bool | None = None,
                   sag_passes: int = SAG_PASSES, pose_labels=None,
                   pose_unit: str = "orientation",
                   design_tolerance: dict | None = None,
                   hold_rule: str = "imprecise",
                   clenched_lateral: bool = False,
                   free_lateral_offsets: bool = False) -> InternalForcePrior:
    """Fit the prior with only what the data identify free (module docstring); the rest held at
    ``design`` (default :data:`DESIGN`; a partial dict overrides some entries). ``inputs``: what
    the law reads as wrist torques (:meth:`InternalForcePrior.fit`); ``jackknife_labels``: each
    recording's jackknife group (:func:`trial_jackknife`, :func:`design_groups`);
    ``crosstalk``: as :meth:`InternalForcePrior.fit`; ``pose_labels``: each recording's
    orientation in a designed experiment (an int from 0, the same for every mass hung in that
    orientation), None for a recording outside the design (free space), for the orientations'
    jackknife (module docstring); with fewer than two orientations it does not run.
    ``pose_unit``: what one of those labels groups, ``"orientation"`` or ``"sign_pair"`` (an
    orientation and its opposite, a paired design's unit:
    :func:`~psmforce.estimators.training.ati_free.hold_orientations`), for the reason it gives.
    ``design_tolerance``: how far each held design value may be off (name -> SI, for example
    :data:`DESIGN_TOLERANCE`; 0 or absent: not moved): a free parameter that the held values
    off by that much would move beyond its needed precision is held as well ("rests on held
    design values"); None (the default, as every committed figure was written): no such check.
    ``hold_rule`` (:data:`HOLD_RULES`): what is held among the parameters listed for their precision
    alone; ``"unresolved"`` keeps those whose design value the data reject free, named in
    ``info["selection"]["estimated"]`` (value, uncertainty: :func:`design_rejected`).
    ``clenched_lateral``: with the load path, every fit counts the clenched samples' lateral
    force channels (:meth:`InternalForcePrior.fit`; module docstring, "The jaws clenched").
    ``free_lateral_offsets``: the lateral force offsets (:data:`LATERAL_OFFSETS`) are never held
    at their design value 0 (module docstring, "The jaws clenched").

    With the load path, the rounds sag the wrist with the design's values
    (:mod:`~psmforce.identification.load_path`); once they have nothing left to hold, the
    selection goes on with the sag the fit's own values give (:func:`fitted_compliance`): a
    round (fit, report, jackknife) with that sag, holding what it finds not identifiable as any
    round does, up to ``sag_passes`` times, until the sag the fit took and the one it gives
    differ by under :data:`SAG_TOLERANCE`. ``info["selection"]["sag"]`` records each pass, and
    each round the sag it took; ``sag_passes=0`` keeps the design's sag."""
    design = {**DESIGN, **(design or {})}
    tolerance = dict(design_tolerance or {})
    if (set(tolerance) - set(NAMES) or not all(
            isinstance(t, (int, float)) and not isinstance(t, bool) and np.isfinite(t) and t >= 0
            for t in tolerance.values())):
        raise IdentificationInputError(f"design_tolerance: values must be finite numbers >= 0 "
                                       f"for parameters of {NAMES}")
    if isinstance(sag_passes, bool) or not isinstance(sag_passes, int) or sag_passes < 0:
        raise IdentificationInputError(f"sag_passes must be an integer >= 0, got "
                                       f"{sag_passes!r}")
    if hold_rule not in HOLD_RULES:
        raise IdentificationInputError(f"hold_rule must be one of {HOLD_RULES}, got "
                                       f"{hold_rule!r}")
    if clenched_lateral is not False and (clenched_lateral is not True
                                          or inputs != "load_path"):
        raise IdentificationInputError(f"clenched_lateral: True only with inputs='load_path', "
                                       f"got {clenched_lateral!r} with {inputs!r}")
    if not isinstance(free_lateral_offsets, bool):
        raise IdentificationInputError(f"free_lateral_offsets must be True or False, got "
                                       f"{free_lateral_offsets!r}")
    unknown = sorted(set(design) - set(NAMES))
    if unknown:
        raise IdentificationInputError(f"design: unknown parameters {unknown} (one of {NAMES})")
    frames = _frames(recordings)
    poses = _pose_groups(pose_labels, len(frames), pose_unit)
    fixed = held_by_reading(inputs, crosstalk)
    why_fixed = {n: {"value": x, "reason": HELD_BY_READING_REASON[n], "fitted_when_listed": None,
                     "round": 0} for n, x in fixed.items()}
    rounds = []
    select = dict(frames=frames, fixed=fixed, why_fixed=why_fixed, rounds=rounds, design=design,
                  psm=psm, provenance=provenance, max_rounds=max_rounds, max_iter=max_iter,
                  inputs=inputs, groups=groups, labels=jackknife_labels, poses=poses,
                  tolerance=tolerance, hold_rule=hold_rule, clenched_lateral=clenched_lateral,
                  free_offsets=LATERAL_OFFSETS if free_lateral_offsets else ())
    prior = _select(compliance=None, **select)
    sag = None
    if inputs == "load_path":
        from dataclasses import asdict
        taken, passes = prior.wrist_compliance, []
        while True:
            given = fitted_compliance(prior, design)
            passes.append({"compliance": asdict(given), "change": _sag_change(taken, given)})
            if passes[-1]["change"] < SAG_TOLERANCE or len(passes) > sag_passes:
                break
            prior = _select(compliance=given, **select)
            taken = given
        sag = {"passes": passes, "converged": passes[-1]["change"] < SAG_TOLERANCE,
               "compliance": asdict(taken)}
    estimated = rounds[-1]["estimated"]
    still = sorted(set(prior.info["identifiability"]["not_identifiable"]) - set(estimated))
    free = [n for n in NAMES if n not in fixed]
    prior.info["selection"] = {
        "method": "fit, list the parameters the identifiability report (with the trial "
                  "jackknife) calls not identifiable, hold them at their design values, refit; "
                  "until nothing is listed",
        "design": design, "design_tolerance": tolerance,
        "jackknife_groups": groups if len(frames) >= groups else None,
        "orientation_jackknife_groups": poses[1] if poses else None,
        "orientation_jackknife_unit": poses[2] if poses else None,
        "rounds": rounds, "fixed": why_fixed,
        "hold_rule": hold_rule,
        **({"clenched_lateral": True} if clenched_lateral else {}),
        **({"free_lateral_offsets": True} if free_lateral_offsets else {}),
        "identified": [n for n in free if n not in still and n not in estimated],
        "estimated": {n: {"value": float(prior.params[NAMES.index(n)]), "uncertainty": u}
                      for n, u in estimated.items()},
        "still_not_identifiable": still,
        "at_bound": list(prior.info["bounds_hit"]),
        **({"sag": sag} if sag is not None else {}),
    }
    prior.info["verdict"] = verdict_line(prior.info["selection"])
    return prior


def _pose_groups(pose_labels, n_frames: int, unit: str):
    """(labels, number of groups, ``unit``) for the orientations' jackknife, or None when
    ``pose_labels`` is None or names fewer than two groups."""
    if unit not in JACKKNIFE_OVER or unit == "trials":
        raise IdentificationInputError(f"pose_unit must be one of "
                                       f"{[u for u in JACKKNIFE_OVER if u != 'trials']}, "
                                       f"got {unit!r}")
    if pose_labels is None:
        return None
    labels = list(pose_labels)
    if len(labels) != n_frames or not all(
            g is None or (isinstance(g, int) and not isinstance(g, bool) and g >= 0)
            for g in labels):
        raise IdentificationInputError(f"pose_labels must be {n_frames} integers >= 0 or None, "
                                       f"one per recording")
    used = sorted({g for g in labels if g is not None})
    if len(used) < 2:
        return None
    rank = {g: k for k, g in enumerate(used)}
    return [None if g is None else rank[g] for g in labels], len(used), unit


def _tiers(listed: dict) -> list[dict]:
    """The reasons ``listed`` by tier (:func:`_tier`), a parameter tied to a listed pretension
    moved to the last (judged again once the pretension is held)."""
    tiers = [{n: r for n, r in listed.items() if _tier(r) == t} for t in range(3)]
    if "pretension_total" in tiers[0]:  # the data see bias_fz - T_tot and T_tot x g_twist:
        for name in TIED_TO_PRETENSION:  # judged again once the pretension is held
            if name in tiers[0]:
                tiers[2][name] = tiers[0].pop(name)
    return tiers


def _select(*, frames, fixed, why_fixed, rounds, design, psm, provenance, max_rounds, max_iter,
            inputs, groups, labels, poses, compliance, tolerance,
            hold_rule, clenched_lateral, free_offsets) -> InternalForcePrior:
    """Rounds of :func:`fit_identified` (fit, report with the jackknife, hold one tier of what
    it lists; the orientations' jackknife, ``poses`` from :func:`_pose_groups`, once nothing
    else is listed) with the load path's sag ``compliance`` (None: the design's), at most
    ``max_rounds``; ``fixed``, ``why_fixed`` and ``rounds`` are updated in place; what is held
    follows ``hold_rule`` (:func:`_holding`). Returns the last round's fit."""
    start = None  # a later pass starts where the last fit ended
    if rounds:
        start = {n: x for n, x in rounds[-1]["parameters"].items() if n not in fixed}
    for round_ in range(max_rounds):
        prior = InternalForcePrior.fit(frames, psm=psm, provenance=provenance, fixed=fixed,
                                       initial=start, max_iter=max_iter, inputs=inputs,
                                       crosstalk="full", compliance=compliance,
                                       held_tolerance=tolerance,
                                       clenched_lateral=clenched_lateral)
        report = prior.info["identifiability"]
        jack = trial_jackknife(frames, prior, fixed, groups, psm, max_iter, inputs, labels,
                               compliance=compliance)
        if jack is not None:
            add_trial_spread(report, prior.params, jack, groups)
        held, estimated = _holding(report, prior.params, design, hold_rule, tolerance,
                                   free_offsets)
        to_fix = next((t for t in _tiers(held) if t), {})
        if not to_fix and poses is not None:
            pose_jack = trial_jackknife(frames, prior, fixed, poses[1], psm, max_iter, inputs,
                                        poses[0], compliance=compliance)
            if pose_jack is not None:
                add_trial_spread(report, prior.params, pose_jack, poses[1], over=poses[2])
            held, estimated = _holding(report, prior.params, design, hold_rule, tolerance,
                                       free_offsets)
            to_fix = next((t for t in _tiers(held) if t), {})
        listed = dict(report["not_identifiable"])
        rounds.append({"fixed": sorted(fixed), "converged": prior.converged,
                       "parameters": {n: float(x) for n, x in zip(NAMES, prior.params)},
                       "bounds_hit": list(prior.info["bounds_hit"]), "not_identifiable": listed,
                       "estimated": estimated,
                       **({"sag": "design" if compliance is None else "own"}
                          if inputs == "load_path" else {})})
        if (not to_fix or len(fixed) + len(to_fix) >= len(NAMES)
                or round_ == max_rounds - 1):  # fix only what a refit follows
            return prior
        for name, reason in to_fix.items():
            why_fixed[name] = {"value": design[name], "reason": reason,
                               "fitted_when_listed": float(prior.params[NAMES.index(name)]),
                               "round": len(rounds)}
            fixed[name] = design[name]
        start = None
    return prior


TIED_TO_PRETENSION = ("bias_fz", "twist_gain")
"""Seen only as ``bias_fz - pretension_total`` and ``pretension_total x twist_gain`` without
slack samples: left free in a round that fixes the pretension."""
STRUCTURAL = ("at its bound", "slack samples", "the data see a combination",
              "errors in variables", "not excited", "lack of fit")
"""Reasons the data cannot pin a parameter down whatever its value (fixed first: a degenerate
fit, such as a pretension at its bound, makes every other estimate wander between trials)."""


def _tier(reason: str) -> int:
    """0: a structural reason (:data:`STRUCTURAL`); 1: statistical only (standard errors, the
    trial jackknife); 2: only tied to a listed parameter. Each round fixes the lowest tier
    listed; the others are judged again on the refit."""
    if any(k in reason for k in STRUCTURAL):
        return 0
    return 2 if reason.startswith("tied to") else 1


def _relative(uncertainty: float, value: float) -> str:
    return f"+-{uncertainty / abs(value):.0%}" if value else f"+-{uncertainty:.2g}"


def _names(names) -> str:
    return ", ".join(names) if names else "none"


def verdict_line(selection: dict) -> str:
    """One line: the identified free parameters, those held at design values, those estimated
    (``hold_rule="unresolved"``: free, with their relative uncertainty), those still not
    identifiable (a fit that ran out of rounds), those at a bound; never "passes" while the
    report lists a free parameter."""
    still, bound = selection["still_not_identifiable"], selection["at_bound"]
    first = selection["rounds"][0]["bounds_hit"] if selection["rounds"] else []
    line = (f"identified (free, 3 SE within {RECOVERY_TOLERANCE:.0%}, an offset's within its "
            f"resolution): "
            f"{_names(selection['identified'])}; fixed at design values (not identifiable): "
            f"{_names(sorted(selection['fixed']))}")
    estimated = selection.get("estimated", {})
    if estimated:
        line += ("; estimated (free: the data reject its design value, but 3 SE exceed "
                 f"{RECOVERY_TOLERANCE:.0%}): " + ", ".join(
                     f"{n} ({_relative(e['uncertainty'], e['value'])})"
                     for n, e in sorted(estimated.items())))
    if still:
        line += f"; free but NOT identifiable: {_names(still)}"
    line += f"; at a bound: {_names(bound)}"
    if first and first != bound:
        line += f" (in the all-free fit: {_names(first)})"
    sag = selection.get("sag")
    if sag is not None and not sag["converged"]:
        line += (f"; the wrist's sag NOT converged: the final fit's own values move it by "
                 f"{100 * sag['passes'][-1]['change']:.2g} % after {len(sag['passes']) - 1} "
                 f"passes with its own sag")
    return line


def all_free_line(selection: dict) -> str:
    """The verdict's first part for a fit with every parameter free that its reading does not
    hold (``fit_prior_cli(..., identify=False)``, ``psmforce fit-prior --all-free``): a curve
    fit, and which of its values its own report does not identify."""
    held = sorted(selection["fixed"])
    return (f"all {len(NAMES) - len(held)} parameters free"
            + (f" ({_names(held)} held by the reading)" if held else "")
            + " (a curve fit: the values listed as not "
            f"identifiable are not the instrument's): identified: "
            f"{_names(selection['identified'])}; NOT identifiable: "
            f"{_names(selection['still_not_identifiable'])}; at a bound: "
            f"{_names(selection['at_bound'])}")
