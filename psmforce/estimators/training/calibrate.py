"""Few-shot calibration of a trained estimator to another instrument (``psmforce calibrate``).

The paper notes that every hand-modified tool is different: pretension, pulley radii, cable
asymmetry, capstan friction and the HEX10's cross-talk and offsets change from one tool to the
next (``InstrumentParams.sample`` draws such a tool on the simulated bench). A model trained on one
tool is calibrated to a new one from a few minutes of recordings made with it:

**Which trials.** The ``train`` split of the new tool's dataset, conditions ``Free`` (free-space
motions: no fixture needed) and ``Traction`` (a spring on the ATI, the bench's simplest loaded
trial), each condition in ``metadata.json`` order, interleaved by minutes (the next trial comes from
the condition with fewer minutes so far, ``Free`` on a tie), and the longest prefix of that order
lasting at most ``minutes``. Traction trials whose trajectory family (metadata ``group``) holds a
free-space trial are left out: on the simulated bench they are the trials a free-space recording
replays, and keeping them out makes each free-space trial a family of its own, so the validation
split (:func:`psmforce.estimators.data.dataset.split_validation`, by family) can never take every
free-space trial away from the prior's refit. The prefix must hold at least :data:`MIN_FREE_TRIALS`
free-space and :data:`MIN_TRACTION_TRIALS` traction trials (one to train on, one to stop on); a
dataset with fewer than ``minutes`` of such trials is refused, so a calibration never claims minutes
it did not have. On the simulated bench at scale 1 the default :data:`DEFAULT_MINUTES` takes one
free-space replay (1.8 min) and four traction trials (0.58 min each), 4.1 min in all.

**What changes per model.** The calibration trials are split into training and validation
(:func:`psmforce.estimators.data.dataset.split_validation`, seeded, by trajectory family). For the
hybrid (inputs derived from the internal-force prior) the prior, the physics that changes with the
tool, is refitted on the training part (as :func:`psmforce.estimators.training.train.fit_prior` in
training: every condition, the known ATI force subtracted; its insertion-effort model, the arm's, is
kept) and its columns recomputed; then every model's last block is finetuned on the training part
with early stopping on the validation part
(:func:`psmforce.estimators.training.train.finetune_model`: the last decoder block of the networks,
the ridge of ``rocket``), with the pretrained scalers. The new checkpoint's provenance names the
calibration trials, their roles and minutes, and the prior before / after.

**Without an ATI** (``free_space=True``, ``psmforce calibrate --free-space``; issue 44). The
calibration trials are the ``train`` split's ``Free`` recordings (external force 0 N by
declaration), and with ``known_loads`` (``--known-loads DIR``) the recordings of known masses hung
at the tip (the weight, in the HEX10 frame, from the kinematics): the selection and its checks are
:mod:`psmforce.estimators.training.ati_free`'s. The prior is refitted and the last block finetuned
as above. What the recordings cannot excite keeps the checkpoint's values; ``psmforce excitation``
designs a motion that excites the rest (``docs/ati_free.md``). The sensor's offsets are the
exception: they are per mount (the sensor is zeroed again at every mount,
:data:`psmforce.identification.prior_remount.PER_MOUNT`), so a checkpoint's offset is never this
mount's, and one held at it is carried by whatever shared term it is confounded with (the
cross-talk, which multiplies a large mean axial reading, takes a held lateral offset's error and
carries it into contact). They are always refitted.

**The instrument identified** (with ``known_loads``, or ``prior_refit="identified"``). The
estimator's prior reads the motor
efforts, which carry the discs' friction: its values are a curve fit, not the instrument's. Where
the external force is known (zero in free space, the weight on a known load) the cables can be
read from the load path instead (:mod:`psmforce.identification.load_path`): every calibration
recording is fitted that way too, what the data cannot pin down held at the design values
(:func:`psmforce.identification.prior_selection.fit_identified`, clenched samples left out but
for their lateral forces with ``clenched_lateral``), and the report's
``instrument_identification`` names what came back. It identifies the instrument;
the checkpoint's prior stays the efforts' one, which a streaming estimator can run.

**The identified instrument in the prior** (``prior_refit="identified"``, ``psmforce calibrate
--prior-refit identified``). The estimator's prior keeps its law and its
reading (the efforts), but what the load path identified is held at the identified values
instead of being refitted as a curve: the pretension, the radii, the capstan, the sensor's
cross-talk where the weights, or the jaws clenched on each other (``clenched_lateral``), pinned
them down. The efforts then fit what is left (the offsets
among it: this mount's), the identifiability rule holding what they cannot pin down at the
checkpoint's values as ``"all"`` does. The provenance's ``prior_refit.held_at_identified`` lists
the carried values (docs/ati_free.md section 4.3).

**Without finetuning** (``finetune=False``, ``psmforce calibrate --no-finetune``). The prior is
refitted as above (on the same training part of the split) and the network kept as trained: no
epoch runs. Without an ATI the finetuning sees only recordings whose external force is zero or a
small weight, and on the bench it raised the axial error of every calibration it was measured
on (docs/ati_free.md section 4.5); the record says ``"finetuned": false``.

**The network kept off the axes the physics carries** (``network_off``, ``psmforce calibrate
--network-off``). A network finetuned without an ATI has never seen a loaded cable; where the
identification pinned down the HEX10's cross-talk of the axial reading into a lateral axis
(:data:`CARRIED_AXES`) and the prior holds it (``prior_refit="identified"``), the physics carries
that axis into contact and the network's residual there only adds what it learnt in free space.
``network_off="carried"`` writes those axes as the checkpoint's ``physics_only_axes``
(:func:`psmforce.estimators.training.checkpoint.residual_gain`): a choice made from what the
identification carried, never from contact data. Axis names instead set them by hand. The
record's ``physics_only_axes`` says which, and why (docs/ati_free.md section 4.5). A calibration
decides them anew for the new instrument (the default, ``"none"``, clears a checkpoint's); a
re-mount (``psmforce remount``) keeps them.

**The network's own prior** (``network_prior="trained"``, ``psmforce calibrate --network-prior
trained``; with ``network_off`` axes, without an ATI). The refit changes the prior the network
reads, and a network that is not finetuned then reads inputs it was never trained on (what
that costs on the bench along the shaft: docs/ati_free.md section 4.7). With
``"trained"`` the checkpoint keeps its prior for the network and holds the refitted one as the
physics-only axes' own (``physics_prior_json``,
:mod:`psmforce.estimators.training.checkpoint`), which answers those axes alone. A calibration
decides it anew; the record's ``network_prior`` says which.

Size: one calibration with its three refits of the prior and the instrument's identification
beside it, in the order a lab runs them; the ATI-free recordings' selection and checks are
:mod:`psmforce.estimators.training.ati_free`'s.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from psmforce.estimators.training.ati_free import (  # noqa: F401  (re-exported: the module's API)
    KNOWN_LOAD_CONDITION, KNOWN_LOAD_FIELD, MAX_FREE_SPACE_FORCE_N, MIN_FREE_SPACE_TRIALS,
    CalibrationError, JACKKNIFE_UNITS, check_minutes, free_space_trials, hold_orientations,
    known_load_trials, trial_minutes)
from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.estimators.data.dataset import (Dataset, Trial, load_dataset, split_validation,
                                              trajectory_group)
from psmforce.estimators.data.hybrid_inputs import prior_to_json
from psmforce.estimators.training.train import TrainConfig, TrainingError, finetune_model
from psmforce.robot.conventions import INSERTION_JOINT
from psmforce.io.recording import joint_column

CALIBRATION_CONDITIONS = ("Free", "Traction")
DEFAULT_MINUTES = 5.0
"""A few minutes of a new tool: on the simulated bench at scale 1, one free-space replay and
four traction trials (module docstring)."""
MIN_FREE_TRIALS = 1
"""The prior's refit needs free-space motion (the internal force alone)."""
MIN_TRACTION_TRIALS = 2
"""One traction trial to finetune on, one to stop on (validation)."""
INSERTION_COLUMNS = tuple(joint_column(INSERTION_JOINT, q) for q in ("velocity", "effort"))
"""What the prior's fit would fit the insertion-effort model on; left out of the refit."""
VALIDATION_FRACTION = 0.1
"""As in training and finetuning; :func:`split_validation` takes at least one family from every
condition with two or more."""
FREE_SPACE_RULE = (
    "train split, condition Free only, in metadata.json order, longest prefix within the "
    "requested minutes; external force 0 N by declaration (free space, no ATI); validation "
    "split by trajectory family (psmforce.estimators.data.dataset.split_validation)")
KNOWN_LOADS_RULE = (
    "; with every train/KnownLoad recording of the known-loads folder, external force = the "
    "hung mass (metadata known_load_kg) x gravity in the HEX10 frame from the recorded joints")
CALIBRATION_RULE = (
    "train split, conditions Free and Traction (traction trials sharing a trajectory family with "
    "a free-space trial left out), each in metadata.json order, interleaved by minutes (next "
    "from the condition with fewer minutes so far, Free on a tie), longest prefix within the "
    "requested minutes; validation split by trajectory family (psmforce.estimators.data.dataset.split_validation)")


def calibration_trials(dataset: Dataset, minutes: float = DEFAULT_MINUTES) -> list[Trial]:
    """The new tool's calibration trials, in the documented order (module docstring)."""
    where = dataset.root
    check_minutes(minutes)
    train = dataset.select(split="train")
    if not train:
        raise CalibrationError(f"{where}: no trials in a 'train' split to calibrate on")
    free = [t for t in train if t.condition == "Free"]
    free_families = {trajectory_group(t) for t in free}
    traction = [t for t in train if t.condition == "Traction"
                and trajectory_group(t) not in free_families]
    if len(free) < MIN_FREE_TRIALS:
        raise CalibrationError(f"{where}: no free-space trials (train/Free) to refit the prior "
                               f"on; calibration needs {MIN_FREE_TRIALS}")
    if len(traction) < MIN_TRACTION_TRIALS:
        raise CalibrationError(f"{where}: {len(traction)} usable traction trials (train/Traction)"
                               f", calibration needs {MIN_TRACTION_TRIALS}")
    available = sum(map(trial_minutes, free + traction))
    if available < minutes:
        raise CalibrationError(f"{where}: asked for {minutes:g} min of calibration trials, the "
                               f"dataset has {available:.2f} min (train Free + Traction); give "
                               f"--minutes {math.floor(available * 100) / 100:g} or record more")
    order = _order(free, traction)
    ends = np.cumsum([trial_minutes(t) for t in order])
    chosen = order[:int(np.searchsorted(ends, minutes, side="right"))]
    n_free = sum(t.condition == "Free" for t in chosen)
    if n_free < MIN_FREE_TRIALS or len(chosen) - n_free < MIN_TRACTION_TRIALS:
        free_seen = np.cumsum([t.condition == "Free" for t in order])
        enough = (free_seen >= MIN_FREE_TRIALS) & (
            np.arange(1, len(order) + 1) - free_seen >= MIN_TRACTION_TRIALS)
        need = ends[int(np.argmax(enough))]
        raise CalibrationError(
            f"too few minutes: {minutes:g} min of {where} hold {n_free} free-space and "
            f"{len(chosen) - n_free} traction trials; calibration needs {MIN_FREE_TRIALS} and "
            f"{MIN_TRACTION_TRIALS}, which takes --minutes {math.ceil(need * 100) / 100:g}")
    return chosen


def _order(free: list[Trial], traction: list[Trial]) -> list[Trial]:
    """Free-space and traction trials interleaved by minutes: the next from the condition with
    fewer minutes so far (Free on a tie), each condition in its given order."""
    queues = {"Free": list(free), "Traction": list(traction)}
    spent = {"Free": 0.0, "Traction": 0.0}
    out: list[Trial] = []
    while any(queues.values()):
        cond = min((c for c in CALIBRATION_CONDITIONS if queues[c]), key=lambda c: spent[c])
        out.append(queues[cond].pop(0))
        spent[cond] += trial_minutes(out[-1])
    return out


def _prior_free_error(prior, trials: list[Trial]) -> dict | None:
    """Per force axis, RMS (N) of the HEX10 force minus the prior on free-space trials (no
    external force: what the prior should explain); None without such trials."""
    from psmforce.identification.prior import channel_metrics
    from psmforce.io.recording import HEX10
    free = [t for t in trials if t.condition == "Free"]
    if not free:
        return None
    y = np.concatenate([t.matrix(HEX10, np.float64) for t in free])
    y_hat = np.concatenate([prior.predict(t.frame) for t in free])
    return {axis: m["rms"] for axis, m in channel_metrics(y, y_hat).items()
            if axis in ("fx", "fy", "fz")}


def instrument_frames(trials: list[Trial]) -> list:
    """The recordings :func:`identify_instrument` fits: each trial's frame without the insertion
    joint's columns (the arm's, not the instrument's)."""
    return [t.frame.drop(columns=list(INSERTION_COLUMNS), errors="ignore") for t in trials]


def identify_instrument(trials: list[Trial], crosstalk: bool | str | None = None,
                        design_tolerance: dict | None = None,
                        jackknife_unit: str = "orientation", hold_rule: str = "imprecise",
                        clenched_lateral: bool = False, free_lateral_offsets: bool = False):
    """The instrument identified from recordings whose external force is known (module
    docstring, "The instrument identified"): the load path's
    :func:`~psmforce.identification.prior_selection.fit_identified` on every trial, the
    insertion joint's columns left out (the arm's, not the instrument's); the jackknife over
    trial groups removes whole masses (each hung in every pose) and quarters of the free-space
    recordings (:func:`~psmforce.identification.prior_selection.design_groups`), and a second
    jackknife leaves out each orientation the weights hang in, with every mass hung in it
    (:func:`~psmforce.estimators.training.ati_free.hold_orientations`). Returns the
    :class:`~psmforce.identification.InternalForcePrior` (``inputs`` "load_path"); ``crosstalk``:
    the sensor's cross-talk it fits (:data:`~psmforce.identification.prior.CROSSTALK_CHOICES`;
    None: the load path's, the axial column); ``design_tolerance``: how far each held design
    value may be off, for the check of what rests on them (``fit_identified``; None: none);
    ``jackknife_unit``: what the second jackknife leaves out at a time, an orientation or a sign
    pair of them (:data:`~psmforce.estimators.training.ati_free.JACKKNIFE_UNITS`);
    ``hold_rule``: what it holds among the parameters listed for their precision alone
    (:data:`~psmforce.identification.prior_selection.HOLD_RULES`); ``clenched_lateral``: the
    clenched samples' lateral forces count (the jaws clenched on each other pin down the
    sensor's lateral cross-talk of the axial reading; ``fit_identified``);
    ``free_lateral_offsets``: the lateral force offsets are never held at 0 (the intercepts
    beside that cross-talk; ``fit_identified``)."""
    from psmforce.identification.prior_selection import design_groups, fit_identified
    frames = instrument_frames(trials)
    masses = [t.params.get(KNOWN_LOAD_FIELD) if t.condition == KNOWN_LOAD_CONDITION else None
              for t in trials]  # each mass hangs in every pose: a replicate of the design
    return fit_identified(frames, inputs="load_path", jackknife_labels=design_groups(masses),
                          pose_labels=hold_orientations(trials, jackknife_unit),
                          pose_unit=jackknife_unit,
                          provenance={"trials": [t.path for t in trials]}, crosstalk=crosstalk,
                          design_tolerance=design_tolerance, hold_rule=hold_rule,
                          clenched_lateral=clenched_lateral,
                          free_lateral_offsets=free_lateral_offsets)


def instrument_report(prior) -> dict:
    """JSON-ready summary of :func:`identify_instrument`'s prior: parameters (SI), identified,
    estimated (``hold_rule="unresolved"``: free, the design value rejected, with its
    uncertainty), fixed at design values with the reason, at a bound, the verdict line."""
    from psmforce.identification.prior import NAMES
    sel = prior.info["selection"]
    clenched = ("their lateral forces counted" if sel.get("clenched_lateral")
                else "clenched samples out")
    return {"reading": f"load path (the known external force's moments; {clenched})",
            "converged": prior.converged,
            "parameters": {n: float(x) for n, x in zip(NAMES, prior.params)},
            "identified": list(sel["identified"]),
            "estimated": dict(sel.get("estimated", {})),
            "fixed": {n: {"value": f["value"], "reason": f["reason"]}
                      for n, f in sel["fixed"].items()},
            "at_bound": list(sel["at_bound"]), "verdict": prior.info["verdict"]}


def identified_values(instrument: dict) -> dict[str, float]:
    """What :func:`instrument_report`'s identification carries into the estimator's prior: each
    parameter it identified or estimated (its design value rejected by the data), at its value
    (SI), the sensor's offsets left out (this mount's: the efforts' refit takes them on the same
    recordings)."""
    from psmforce.identification.prior_identifiability import is_offset
    carried = [*instrument["identified"], *instrument.get("estimated", {})]
    return {n: float(instrument["parameters"][n]) for n in carried if not is_offset(n)}


PRIOR_REFITS = ("all", "per_mount", "identified")
"""How :func:`calibrate` refits the hybrid's prior without an ATI (its ``prior_refit``)."""


CARRIED_AXES = {"Fx": "crosstalk_fx", "Fy": "crosstalk_fy"}
"""Lateral axis -> the HEX10's cross-talk term (the axial reading into that axis) which, held at
its identified value in the prior, lets the physics carry the axis into contact: the internal
axial force grows with the tip load there, and only the cross-talk turns it into a lateral
reading (module docstring, "The network kept off the axes the physics carries")."""
NETWORK_OFF_RULES = ("none", "carried")
"""``network_off`` as a rule: no axis, or :data:`CARRIED_AXES`' axes whose term the prior holds
at its identified value; a sequence of axis names sets them by hand."""


def network_off_axes(network_off, carried) -> tuple[str, ...]:
    """The axes ``network_off`` keeps the network off (:data:`NETWORK_OFF_RULES`, or axis
    names of :data:`psmforce.io.recording.AXES`), given the prior's values held at the
    identification's (``carried``: names -> values), in axis order."""
    from psmforce.io.recording import AXES
    if network_off == "none":
        return ()
    if network_off == "carried":
        return tuple(a for a, term in CARRIED_AXES.items() if term in carried)
    if isinstance(network_off, str) or not all(a in AXES for a in network_off) \
            or len(set(network_off)) != len(network_off):
        raise CalibrationError(f"network_off must be one of {NETWORK_OFF_RULES} or distinct "
                               f"axis names of {list(AXES)}, got {network_off!r}")
    return tuple(a for a in AXES if a in network_off)


NETWORK_PRIORS = ("calibrated", "trained")
"""Which prior the network reads after :func:`calibrate` (its ``network_prior``): the refitted
one, or the one it was trained with, the refitted prior then answering the physics-only axes
alone (module docstring, "The network's own prior")."""


HELD_VALUES = ("as-held", "checked")
"""What the instrument's identification does with the design values it holds
(:func:`calibrate`'s ``held_values``)."""


def calibrate(checkpoint: str | Path, data_dir: str | Path, out: str | Path, *,
              minutes: float = DEFAULT_MINUTES, epochs: int = 100, seed: int = 0,
              device: str = "cpu", train_config=None, free_space: bool = False,
              known_loads: str | Path | None = None, prior_refit: str = "all",
              held_values: str = "as-held", jackknife_unit: str = "orientation",
              hold_rule: str = "imprecise", network_off="none",
              finetune: bool = True, network_prior: str = "calibrated",
              clenched_lateral: bool = False, free_lateral_offsets: bool = False) -> dict:
    """Calibrate a trained checkpoint to the instrument recorded in ``data_dir`` from its first
    ``minutes`` of calibration trials (module docstring) and write ``out``. ``seed``: the validation
    split and the finetuning's shuffling; ``train_config``: a
    :class:`psmforce.estimators.training.train.TrainConfig` (default: finetuning's). Returns a
    summary: the finetuning report, the calibration trials with their roles and minutes, and for the
    hybrid the prior's free-space error before and after its refit. ``free_space``: calibrate
    without an ATI, on free-space recordings only; ``known_loads``: with it, also on the
    known-load recordings of that folder (module docstring). ``prior_refit`` (without an ATI):
    ``"all"``, the prior's law refitted, what the recordings cannot pin down held at the
    checkpoint's values; ``"per_mount"``, only the pretension and the force offsets
    (:data:`~psmforce.identification.prior_remount.FORCE_PER_MOUNT`) re-estimated on the
    free-space recordings, every other parameter the checkpoint's, as after a re-mount
    (docs/ati_free.md section 3); ``"identified"``, what the instrument's
    identification through the load path (on the known loads and the free-space recordings, or
    on these alone) identified held at its identified values (the
    sensor's offsets excepted: this mount's, refitted), the rest refitted as ``"all"`` does
    (module docstring, "The identified instrument in the prior"). ``held_values`` (with
    the identification): ``"checked"`` also
    holds what the held design values, each off by its
    :data:`~psmforce.identification.prior_selection.DESIGN_TOLERANCE`, would move beyond its
    needed precision (:func:`identify_instrument`); ``"as-held"``: no such check.
    ``jackknife_unit`` (with the identification): what the identification's jackknife over the
    weights' orientations leaves out at a time, ``"orientation"`` or ``"sign_pair"`` (an
    orientation with its opposite, for a paired design:
    :func:`~psmforce.estimators.training.ati_free.hold_orientations`). ``hold_rule`` (with
    the identification): what it holds among the parameters listed for their
    precision alone (:data:`~psmforce.identification.prior_selection.HOLD_RULES`):
    ``"imprecise"`` every one, ``"unresolved"`` only those
    whose design value the data do not reject, the others estimated (and carried by
    ``"identified"``). ``clenched_lateral`` (with the identification): it counts the clenched
    samples' lateral forces; ``free_lateral_offsets``: it never holds the lateral force offsets
    (:func:`identify_instrument`). ``network_off``: the axes whose estimate is the prior alone
    (:func:`network_off_axes`; ``"carried"`` only with ``prior_refit="identified"``).
    ``finetune=False``: the prior refitted, the network left as trained (module docstring,
    "Without finetuning"); refused for a model without a prior (nothing would change).
    ``network_prior`` (:data:`NETWORK_PRIORS`): ``"trained"`` keeps the checkpoint's prior as
    the one the network reads and stores the refitted prior as the physics-only axes' own
    (module docstring, "The network's own prior"); it needs ``network_off`` axes (checked again
    once ``"carried"`` has named them) and, without ``free_space``, is refused."""
    from psmforce.identification import InternalForcePrior
    from psmforce.identification.errors import NotConvergedError
    from psmforce.identification.prior import NAMES, held_by_reading
    from psmforce.identification.prior_identifiability import is_offset
    if isinstance(epochs, bool) or not isinstance(epochs, int) or epochs < 1:
        raise TrainingError(f"epochs must be an integer >= 1, got {epochs!r}")
    if Path(out).resolve() == Path(checkpoint).resolve():
        raise TrainingError(f"out {out} is the checkpoint being calibrated: refusing to write "
                            f"over its input (give another file)")
    if prior_refit not in PRIOR_REFITS or (prior_refit != "all" and not free_space):
        raise CalibrationError(f"prior_refit must be one of {PRIOR_REFITS} ('per_mount' and "
                               f"'identified' only without an ATI, free_space=True), got "
                               f"{prior_refit!r}")
    if held_values not in HELD_VALUES:
        raise CalibrationError(f"held_values must be one of {HELD_VALUES}, got {held_values!r}")
    if jackknife_unit not in JACKKNIFE_UNITS:
        raise CalibrationError(f"jackknife_unit must be one of {JACKKNIFE_UNITS}, got "
                               f"{jackknife_unit!r}")
    from psmforce.identification.prior_selection import HOLD_RULES
    if hold_rule not in HOLD_RULES:
        raise CalibrationError(f"hold_rule must be one of {HOLD_RULES}, got {hold_rule!r}")
    for name, value in (("clenched_lateral", clenched_lateral),
                        ("free_lateral_offsets", free_lateral_offsets)):
        if not isinstance(value, bool):
            raise CalibrationError(f"{name} must be True or False, got {value!r}")
    for name, value, default in (("held_values", held_values, "as-held"),
                                 ("jackknife_unit", jackknife_unit, "orientation"),
                                 ("hold_rule", hold_rule, "imprecise"),
                                 ("clenched_lateral", clenched_lateral, False),
                                 ("free_lateral_offsets", free_lateral_offsets, False)):
        if value != default and known_loads is None and prior_refit != "identified":
            raise CalibrationError(f"{name}: only with known_loads or prior_refit='identified' "
                                   f"(the instrument's identification through the load path)")
    if known_loads is not None and not free_space:
        raise CalibrationError("known_loads: only without an ATI (free_space=True, "
                               "--free-space); an ATI calibration reads the loads it measures")
    if network_off == "carried" and prior_refit != "identified":
        raise CalibrationError("network_off: 'carried' only with prior_refit='identified' (the "
                               "axes whose cross-talk the identification carried into the prior)")
    wanted = network_off_axes(network_off, {t: 0.0 for t in CARRIED_AXES.values()})
    if network_prior not in NETWORK_PRIORS:
        raise CalibrationError(f"network_prior must be one of {NETWORK_PRIORS}, got "
                               f"{network_prior!r}")
    if network_prior == "trained" and (not wanted or not free_space):
        raise CalibrationError("network_prior: 'trained' needs network_off axes and "
                               "free_space=True (the refitted prior answers the axes the "
                               "network is kept off; with an ATI the network is finetuned on "
                               "the prior it reads)")
    if not isinstance(finetune, bool):
        raise CalibrationError(f"finetune must be True or False, got {finetune!r}")
    ckpt = load_checkpoint(checkpoint, device)
    if network_prior == "trained" and ckpt.prior_json is None:
        raise CalibrationError(f"network_prior: 'trained': {checkpoint} holds a "
                               f"'{ckpt.model_name}' model without a prior")
    if not finetune and ckpt.prior_json is None:
        raise CalibrationError(f"finetune=False: {checkpoint} holds a '{ckpt.model_name}' model "
                               f"without a prior, so nothing would be calibrated")
    from psmforce.estimators.training.checkpoint import physics_only_problem
    from psmforce.estimators.networks.uncertainty import predicts_variance
    why = physics_only_problem(wanted, ckpt.base_columns, predicts_variance(ckpt.model))
    if why is not None:  # before minutes of fitting, not at the save
        raise CalibrationError(f"network_off: {checkpoint}: {why}")
    dataset = load_dataset(data_dir, require_targets=not free_space)
    chosen = (free_space_trials if free_space else calibration_trials)(dataset, minutes)
    loads_root = None
    if known_loads is not None:
        loads = load_dataset(known_loads, require_targets=False)
        loads_root = loads.root
        known = known_load_trials(loads)
        taken = {t.path for t in chosen} & {t.path for t in known}
        if taken:
            # the checkpoint's provenance and the validation split key trials by path
            raise CalibrationError(f"{known_loads}: recording path {sorted(taken)[0]} is also "
                                   f"one of {data_dir}'s: give the known loads their own paths")
        chosen = chosen + known
    instrument = None
    if loads_root is not None or prior_refit == "identified":
        from psmforce.identification.errors import IdentificationInputError
        try:
            from psmforce.identification.prior_selection import DESIGN_TOLERANCE
            instrument = instrument_report(identify_instrument(
                chosen, design_tolerance=DESIGN_TOLERANCE if held_values == "checked" else None,
                jackknife_unit=jackknife_unit, hold_rule=hold_rule,
                clenched_lateral=clenched_lateral, free_lateral_offsets=free_lateral_offsets))
        except IdentificationInputError as err:
            raise CalibrationError(f"{known_loads or data_dir}: identifying the instrument "
                                   f"through the load path: {err}") from None
    train_trials, val_trials = split_validation(chosen, VALIDATION_FRACTION, seed)
    calibration = Dataset(dataset.root, chosen, dataset.metadata)
    prior_report = None
    if ckpt.prior_json is not None:
        old = ckpt.prior()
        # The insertion-effort model is the arm's (carriage gravity and friction), not the
        # tool's, and Free + Traction trials barely move the insertion: refitted on them its
        # friction terms are not identifiable (on a scale-0.02 bench its cross-validated error
        # was 120 N; on a scale-0.01 one the fit refuses). The fit sees the recordings without
        # the insertion joint's effort, so it fits the cable model only, as in training
        # otherwise (psmforce.estimators.training.train.fit_prior: every condition, the ATI force subtracted), and
        # the trained insertion model is kept.
        frames = [t.frame.drop(columns=list(INSERTION_COLUMNS)) for t in train_trials]
        provenance = {"trials": [t.path for t in train_trials]}
        held, unseen, carried = {}, {}, {}
        if prior_refit == "per_mount":
            from psmforce.identification.errors import IdentificationInputError
            from psmforce.identification.prior_remount import FORCE_PER_MOUNT, recalibrate
            free = [f for f, t in zip(frames, train_trials) if t.condition == "Free"]
            try:
                fitted = recalibrate(old, free, per_mount=FORCE_PER_MOUNT, angles=()).prior
            except IdentificationInputError as err:
                raise CalibrationError(f"{data_dir}: {err}") from None
            held = {n: float(old.params[NAMES.index(n)]) for n in NAMES
                    if n not in FORCE_PER_MOUNT}
        else:  # the law the checkpoint was trained with: with or without the cross-talk
            carried = identified_values(instrument) if prior_refit == "identified" else {}
            fitted = InternalForcePrior.fit(frames, provenance=provenance, fixed=carried or None,
                                            crosstalk=old.crosstalk)
        if free_space and prior_refit != "per_mount":
            # Without an ATI what the recordings cannot excite (the fit's own identifiability
            # report names it) keeps the checkpoint's value instead of drifting with noise; an
            # offset is this mount's, never the checkpoint's (module docstring).
            unseen = fitted.info.get("identifiability", {}).get("not_identifiable", {})
            held = {n: float(old.params[NAMES.index(n)]) for n in sorted(unseen)
                    if not is_offset(n) and n not in carried}
            if held:
                fitted = InternalForcePrior.fit(frames, provenance=provenance,
                                                fixed={**held, **carried},
                                                crosstalk=old.crosstalk)
        new = dataclasses.replace(fitted, insertion=old.insertion)
        try:
            if network_prior == "trained":
                ckpt.physics_prior_json = prior_to_json(new)
            else:
                ckpt.prior_json, ckpt.physics_prior_json = prior_to_json(new), None
        except NotConvergedError as err:
            raise CalibrationError(f"{data_dir}: the prior's refit on the calibration trials "
                                   f"did not converge ({err}); give more --minutes") from None
        # the refit saw the training part: its free-space error there is in-sample, the
        # validation part's (when it holds a free-space trial) is not
        errors = {role: {"before": _prior_free_error(old, trials),
                         "after": _prior_free_error(new, trials)}
                  for role, trials in (("train", train_trials), ("validation", val_trials))}
        reading = (held_by_reading(new.inputs, old.crosstalk) if prior_refit != "per_mount"
                   else {})
        prior_report = {
            "refitted_on": [t.path for t in train_trials],
            "insertion_model": "kept from the checkpoint (the arm's, not the tool's)",
            "held_from_checkpoint": held, "refit": prior_refit,
            "held_at_identified": carried,
            "held_by_reading": sorted(n for n in reading if n not in held and n not in carried),
            "offsets_refitted_although_listed": sorted(n for n in unseen if is_offset(n)),
            "free_space_rms_n": {r: e for r, e in errors.items() if e["before"] is not None},
            "parameters_before": dict(zip(NAMES, old.params.tolist())),
            "parameters_after": dict(zip(NAMES, new.params.tolist()))}
    carried_now = (prior_report or {}).get("held_at_identified", {})
    ckpt.physics_only_axes = network_off_axes(network_off, carried_now)
    if network_prior == "trained" and not ckpt.physics_only_axes:
        raise CalibrationError(f"network_prior: 'trained': {network_off!r} named no axis here "
                               f"(the identification carried no lateral cross-talk), so the "
                               f"refitted prior would answer nothing; nothing written")
    ckpt.derive(calibration)
    cfg = train_config or TrainConfig()
    cfg = TrainConfig(**{**cfg.to_dict(), "max_epochs": epochs, "seed": seed, "device": device})
    report = (finetune_model(ckpt, train_trials, val_trials, cfg, desc="calibrate") if finetune
              else {"trainable_parameters": 0, "epochs_run": 0, "stopped_by": "not finetuned",
                    "converged": None, "best_val_loss": None})
    roles = {t.path: "train" for t in train_trials} | {t.path: "validation" for t in val_trials}
    record = {
        "data_dir": str(data_dir), "tool": dataset.metadata.get("tool"),
        "known_loads_dir": None if loads_root is None else str(known_loads),
        "rule": (FREE_SPACE_RULE + (KNOWN_LOADS_RULE if loads_root is not None else "")
                 if free_space else CALIBRATION_RULE),
        "reference": ("none: external force 0 N in free space"
                      + (", the hung weight on known loads" if loads_root is not None else "")
                      if free_space else "ATI"),
        "minutes_requested": float(minutes),
        "minutes_used": round(sum(map(trial_minutes, chosen)), 4),
        "minutes_by_condition": {c: round(sum(trial_minutes(t) for t in chosen
                                              if t.condition == c), 4)
                                 for c in CALIBRATION_CONDITIONS + (KNOWN_LOAD_CONDITION,)},
        "trials": [{"path": t.path, "condition": t.condition, "role": roles[t.path],
                    "minutes": round(trial_minutes(t), 4)} for t in chosen],
        "prior_refit": prior_report,
        "instrument_identification": instrument,
        "physics_only_axes": {
            "axes": list(ckpt.physics_only_axes),
            "rule": network_off if isinstance(network_off, str) else "by hand",
            "why": {a: f"{t} held at its identified value in the prior"
                    for a, t in CARRIED_AXES.items() if a in ckpt.physics_only_axes}
            if network_off == "carried" else {}},
        "finetuned": finetune,
        "network_prior": network_prior,
        "finetune_config": cfg.to_dict() if finetune else None,
        "trainable_parameters": report["trainable_parameters"],
        "epochs_run": report["epochs_run"], "stopped_by": report["stopped_by"],
        "converged": report["converged"], "best_val_loss": report["best_val_loss"]}
    ckpt.provenance = {**ckpt.provenance, "calibrated_from": str(checkpoint),
                       "calibration": record}
    ckpt.save(out)
    return ({k: v for k, v in report.items() if k != "history"}
            | {"checkpoint": str(out), "calibration": record})
