"""The hybrid estimator's inputs: HEX10 reading compensated by the internal-force prior.

The prior (``psmforce.identification.InternalForcePrior`` or any object with the same
interface) predicts the wrench the HEX10 reads when no external force acts (cable tensions,
friction, distal gravity, bias), in the HEX10 frame, [force N; moment Nm]. The hybrid feeds the
network the *compensated* reading ``comp = HEX10 - prior`` (columns :data:`COMPENSATED_HEX10`,
same frame, units and signs as ``fx .. tz``) in place of the raw HEX10 columns of the paper's 21
inputs (:data:`HYBRID_FEATURES`), and the network learns the residual:

    estimate (N, HEX10 frame) = (hex10_f - prior_f) + target_scaler.inverse(net(scaled inputs))

with the compensated lateral force as the base of x and y. ``BASE_COLUMNS`` (= ``comp_fx,
comp_fy, insertion_fz``) are added to the un-scaled network output, as
:func:`psmforce.estimators.evaluation.evaluate.predict_trial` does for any model with base columns.

**Along the shaft the base is the arm's own measurement** (:data:`INSERTION_FZ`): the prior's
insertion model (:mod:`psmforce.identification.insertion`) turns the insertion joint's effort
into the external axial force, gravity entering through the shaft direction, so it holds in arm
configurations the training never visited. Why this design and not
``insertion_fz`` as an input only: docs/results.md (the variants, chosen on validation
trials by ``studies/hybrid_design.py``).

**Residual only where the base helps** (:func:`select_base`). Laterally the compensated reading is
the tip force plus a small error (cables run along the shaft and carry little shear), so the
residual is far smaller than the force. Axially it is not: a tip load makes a moment about the wrist
pulleys that the cables resist with tensions many times the load (jaw length >> pulley radius), and
what of that compression the prior does not explain (capstan friction, hysteresis, elasticity under
load) can exceed the axial tip force itself (``studies/hybrid_design.py`` prints both spreads). An
axis whose base does not shrink the target on the training trials gets
:data:`psmforce.estimators.data.dataset.NO_BASE`: there the network predicts the force, with
``comp_fz`` still among its inputs. (The default z base is ``insertion_fz``, not ``comp_fz``, for
this reason; the check still runs.)

:data:`PRIOR_FZ` (``prior_fz``): the prior's internal axial force itself (N, HEX10 frame,
compression negative), an extra input (:data:`HYBRID_FEATURES_PRIOR_FZ`, the default inputs of
:func:`hybrid_columns`; chosen on validation, ``studies/hybrid_design.py``). Why: what
the prior misses along the shaft (capstan friction, hysteresis, wrist elasticity) depends on the
cable load it predicts and on its regime (taut or slack, direction of sliding), with a sign that
changes between regimes, so the Fz residual ``ati_fz - comp_fz`` is not a function of ``comp_*``
alone; without ``prior_fz`` the network must re-derive the prior's nonlinear internal force from
the joint states to learn it.

**The insertion joint's state** (:data:`INSERTION_STATE`, velocity and position) is an input,
though the paper left the first three joints' positions and velocities out so that its model
would not learn the arm's gross pose. ``insertion_fz`` is the insertion effort minus an
identified model of the stage; what that model leaves (friction that varies along the stroke,
its stiction and Stribeck regime, a port's seal friction, which depends on the sliding velocity
and the depth) is a function of the insertion velocity and position, so without them the
network can only average it out. Chosen on the validation trials of the design bench (seed 0)
with and without a port: ``studies/hybrid_port_design.py``, docs/results.md. The other
joints' positions and velocities stay out, as in the paper.

``use_prior=False`` (the "hybrid without the prior" ablation, :func:`hybrid_columns`): the same
network on the paper's raw 21 inputs with the raw HEX10 force as the base, i.e. the prior
replaced by zero.

Prior interface used here: ``predict(frame: DataFrame) -> (N, 6)`` for whole recordings,
``input_columns`` (the recording columns it reads), ``predict_sample(values) -> (6,)`` for one
sample given as a 1-D array in ``input_columns`` order (the streaming path), ``to_json()`` (the
JSON its ``save(path)`` writes, kept in checkpoints; read back by ``InternalForcePrior.from_json``,
in memory); optionally ``insertion`` (not None: an insertion model), with
``insertion_axial_force(frame) -> (N,)`` and :data:`INSERTION_FZ` as a 7th ``predict_sample``
entry. :class:`SamplePrior` gives an ``InternalForcePrior`` (whose per-sample
path is ``predict_one(positions, efforts, velocities, g_hex)``) that interface; the gravity
direction in the HEX10 frame comes from the PSM's forward kinematics, once per sample.

:class:`HybridInputs` turns raw recorded signals into the network's scaled-input order and the
base, for a whole recording (vectorised) or one sample (preallocated buffers).

**A prior of the physics-only axes' own** (``physics_prior``; a checkpoint's
``physics_prior_json``, ``psmforce calibrate --network-prior trained``). An axis answered by the
base alone (a checkpoint's ``physics_only_axes``) needs no network, so its base may come from a
prior other than the one the network reads: a calibration that refits the prior without
finetuning the network can leave the network's inputs as it was trained on them and let the
refitted prior answer the physics-only axes alone. Every other column, the network's inputs and
the base of the axes it answers, comes from ``prior``. :func:`physics_base` (a whole recording)
and :meth:`HybridInputs.sample` (one sample, the prior's state carried as the other's) compute
it the same way; only :data:`PHYSICS_BASE_COLUMNS` can be answered so.

Size: the inputs' columns, the prior's per-sample interface and the two priors' bases, one
contract for training, evaluation, streaming and export.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from psmforce.estimators.data.dataset import FEATURE_SETS, NO_BASE, resolve_features, target_matrix
from psmforce.robot.conventions import INSERTION_JOINT, JOINTS, WRIST_JOINTS
from psmforce.io.recording import (AXES, HEX10, HEX10_FORCE, JOINT_EFFORTS, JOINT_POSITIONS,
                                 JOINT_VELOCITIES, PAPER_FEATURES, joint_column)

COMPENSATED_HEX10 = tuple(f"comp_{c}" for c in HEX10)
"""HEX10 reading minus the prior's internal wrench: comp_fx .. comp_tz (N, Nm, HEX10 frame)."""
PRIOR_FZ = "prior_fz"
"""The prior's internal axial force (N, HEX10 frame, shaft compression negative)."""
INSERTION_FZ = "insertion_fz"
"""The external force along the shaft from the insertion joint's effort, by the prior's insertion
model (N, HEX10 z, a press on the tip negative; :mod:`psmforce.identification.insertion`)."""
PRIOR_WRENCH = tuple(f"prior_{c}" for c in HEX10)
"""The prior's internal wrench itself, prior_fx .. prior_tz (N, Nm, HEX10 frame; ``prior_fz`` is
:data:`PRIOR_FZ`): inputs beside the raw HEX10 reading (:data:`HYBRID_INPUTS_RAW_AND_PRIOR`)."""
PRIOR_COLUMNS = COMPENSATED_HEX10 + (PRIOR_FZ, INSERTION_FZ) + tuple(
    c for c in PRIOR_WRENCH if c != PRIOR_FZ)
"""Every column derived from the prior (:func:`compensated_hex10`)."""
BASE_COLUMNS = COMPENSATED_HEX10[:2] + (INSERTION_FZ,)
"""Added to the network's un-scaled output: the prior-compensated HEX10 lateral force, and along
the shaft the axial force from the insertion effort (module docstring)."""
HYBRID_FEATURES = tuple(f"comp_{c}" if c in HEX10 else c for c in PAPER_FEATURES)
"""The paper's 21 inputs in its order, HEX10 columns replaced by their compensated values."""
HYBRID_FEATURES_PRIOR_FZ = HYBRID_FEATURES + (PRIOR_FZ,)
""":data:`HYBRID_FEATURES` plus the prior's internal fz (see the module docstring)."""
HYBRID_FEATURES_INSERTION = HYBRID_FEATURES_PRIOR_FZ + (INSERTION_FZ,)
""":data:`HYBRID_FEATURES_PRIOR_FZ` plus :data:`INSERTION_FZ`."""
INSERTION_STATE = (joint_column(INSERTION_JOINT, "velocity"),
                   joint_column(INSERTION_JOINT, "position"))
"""The insertion joint's velocity (m/s) and position (m): what the residual of ``insertion_fz``
depends on (module docstring)."""
HYBRID_INPUTS = HYBRID_FEATURES_INSERTION + INSERTION_STATE
"""The hybrid's default inputs: :data:`HYBRID_FEATURES_INSERTION` plus :data:`INSERTION_STATE`."""
HYBRID_INPUTS_RAW_AND_PRIOR = (PAPER_FEATURES + PRIOR_WRENCH + (INSERTION_FZ,)
                               + INSERTION_STATE)
"""The paper's 21 inputs with the raw HEX10 reading, the prior's internal wrench beside it
(not subtracted from it: nothing the reading carries is lost where the prior is wrong), the
axial force from the insertion effort and the insertion state (docs/results.md, "The prior,
axis by axis")."""


_SIGNAL_GROUPS = (HEX10, JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS)
"""The signal groups the paper's input ablations remove (:data:`psmforce.estimators.data.dataset.FEATURE_SETS`)."""


class HybridInputError(ValueError):
    """Signals or a prior the hybrid's inputs cannot be built from; the message says which."""


def hybrid_columns(use_prior: bool = True) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(input features, base columns) of the hybrid, or of its no-prior ablation."""
    if use_prior:
        return HYBRID_INPUTS, BASE_COLUMNS
    return PAPER_FEATURES, HEX10_FORCE


def hybrid_feature_set(features: str | Sequence[str] | None = None,
                       use_prior: bool = True) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(input columns, base columns) of the hybrid for a feature-set name of
    :data:`psmforce.estimators.data.dataset.FEATURE_SETS` (None = "paper") or an explicit list.

    With the prior, a named set is the hybrid's inputs (:func:`hybrid_columns`) minus the columns
    whose recorded source that ablation removes (a compensated HEX10 column's source is its HEX10
    column; an ablation removes a whole signal group, so "no_positions" removes
    :data:`INSERTION_STATE`'s position too); the base (compensated lateral HEX10 force,
    ``insertion_fz``), ``prior_fz`` and ``insertion_fz`` stay, since they are the prior's output,
    not a recorded input. The trainers then drop the base on axes where it does not help
    (:func:`select_base`). Without the prior (the ablation of :func:`hybrid_columns`), the named set
    itself with the raw HEX10 force as base.
    """
    all_inputs, base = hybrid_columns(use_prior)
    if features is None or (isinstance(features, str) and features == "paper"):
        return tuple(all_inputs), tuple(base)
    if not isinstance(features, str):
        return resolve_features(features), tuple(base)
    kept = set(resolve_features(features))
    removed = {c for group in _SIGNAL_GROUPS if set(group) & set(PAPER_FEATURES) - kept
               for c in group}
    source = dict(zip(COMPENSATED_HEX10, HEX10))
    return tuple(c for c in all_inputs if source.get(c, c) not in removed), tuple(base)


def select_base(trials, base_columns: Sequence[str]) -> tuple[str, ...]:
    """``base_columns`` with :data:`psmforce.estimators.data.dataset.NO_BASE` on every axis where subtracting the base
    does not lower the target's variance over ``trials`` (the training trials; module docstring).
    """
    if len(base_columns) != 3:
        raise HybridInputError(f"base needs 3 columns (x, y, z), got {list(base_columns)}")
    if not trials:
        raise HybridInputError("no training trials to select the base on")
    force = np.concatenate([target_matrix(t, (), np.float64) for t in trials])
    residual = np.concatenate([target_matrix(t, base_columns, np.float64) for t in trials])
    helps = residual.var(axis=0) < force.var(axis=0)
    return tuple(c if keep else NO_BASE for c, keep in zip(base_columns, helps))


def compensated_hex10(frame: pd.DataFrame, prior) -> dict[str, np.ndarray]:
    """{comp_fx .. comp_tz, prior_fx .. prior_tz[, insertion_fz]: (N,)} for a whole recording:
    HEX10 reading minus ``prior.predict``, the prior's internal wrench, and where the prior has
    an insertion model, the axial force from the insertion effort (:data:`PRIOR_COLUMNS`)."""
    _check_reads_efforts(prior)
    internal = np.asarray(prior.predict(frame), dtype=np.float64)
    if internal.shape != (len(frame), 6):
        raise HybridInputError(f"prior.predict returned shape {internal.shape}, expected "
                               f"({len(frame)}, 6)")
    hex10 = frame[list(HEX10)].to_numpy(dtype=np.float64)
    comp = {name: hex10[:, k] - internal[:, k] for k, name in enumerate(COMPENSATED_HEX10)}
    comp.update({name: internal[:, k] for k, name in enumerate(PRIOR_WRENCH)})
    if getattr(prior, "insertion", None) is not None:
        comp[INSERTION_FZ] = prior.insertion_axial_force(frame)
    return comp


PHYSICS_BASE_COLUMNS = COMPENSATED_HEX10[:3] + (INSERTION_FZ,)
"""Base columns a prior computes, so that a prior of the physics-only axes' own can answer them
(module docstring, "A prior of the physics-only axes' own")."""


def physics_base_problem(base_columns: Sequence[str], physics_axes: Sequence[str]) -> str | None:
    """Why a prior of their own cannot answer ``physics_axes`` (a checkpoint's
    ``physics_only_axes``) of a model with these base columns, or None when it can."""
    if not physics_axes:
        return ("a prior for the physics-only axes needs at least one such axis (it would "
                "answer nothing)")
    if len(base_columns) != 3:
        return "a prior for the physics-only axes needs a residual model (3 base columns)"
    bare = [a for a in physics_axes if a not in AXES
            or base_columns[AXES.index(a)] not in PHYSICS_BASE_COLUMNS]
    if bare:
        return (f"a prior for the physics-only axes {bare}: their base columns do not come "
                f"from a prior (only {list(PHYSICS_BASE_COLUMNS)} do)")
    return None


def physics_base(frame: pd.DataFrame, prior, base_columns: Sequence[str],
                 physics_axes: Sequence[str]) -> dict[int, np.ndarray]:
    """{axis index: (N,) base} of each of ``physics_axes`` computed with ``prior``, the prior of
    the physics-only axes' own, for a whole recording (module docstring)."""
    why = physics_base_problem(base_columns, physics_axes)
    if why is not None:
        raise HybridInputError(why)
    cols = compensated_hex10(frame, prior)
    needed = {AXES.index(a): base_columns[AXES.index(a)] for a in physics_axes}
    if INSERTION_FZ in needed.values() and INSERTION_FZ not in cols:
        raise HybridInputError(f"column {INSERTION_FZ!r} needs a prior with an insertion model")
    return {k: cols[c] for k, c in needed.items()}


def _check_reads_efforts(prior) -> None:
    """A prior that reads the cables from the known tip force (``inputs == "load_path"``,
    :mod:`psmforce.identification.load_path`) would hand the network the target it should
    estimate: refused."""
    if getattr(prior, "inputs", "efforts") != "efforts":
        raise HybridInputError(
            f"this prior reads its wrist torques from the known tip force (inputs "
            f"{prior.inputs!r}): an estimator needs one that reads the motor efforts (fit it "
            f"without --load-path)")


def add_prior_columns(dataset, prior) -> None:
    """Append the prior's columns (:data:`PRIOR_COLUMNS`) to every trial of a
    :class:`psmforce.estimators.data.dataset.Dataset`."""
    dataset.add_columns(lambda trial: compensated_hex10(trial.frame, prior))


def prior_to_json(prior) -> str:
    """The prior as the JSON text its ``save`` writes (stored in checkpoints and exports),
    made in memory (``InternalForcePrior.to_json``)."""
    return prior.to_json()


def prior_from_json(text: str):
    """An ``InternalForcePrior`` from the JSON text of :func:`prior_to_json`, read in memory
    with the checks of its ``load``."""
    from psmforce.identification.prior import InternalForcePrior
    if not text:
        raise HybridInputError("no prior JSON (the checkpoint was not trained with a prior)")
    return InternalForcePrior.from_json(text)


class HexRotation:
    """R_base_hex10(q) (3, 3) for one configuration q (7,) (dVRK joint positions, jaw last):
    Pinocchio's forward kinematics on the PSM's own model (``psm.model``, frame ``hex10``).

    Equals ``psm.rotation(q, "hex10")`` (tests/estimators/test_streaming.py) at ~3 us instead of
    ~250 us: ``PSM.rotation`` is vectorised over many configurations and its per-call overhead
    dominates for one sample.
    """

    def __init__(self, psm):
        import pinocchio as pin  # bound once: an import per call costs about as much as the FK
        self._model = psm.model
        self._data = psm.model.createData()
        self._frame = psm.model.getFrameId("hex10")
        self._forward_kinematics = pin.forwardKinematics
        self._frame_placement = pin.updateFramePlacement

    def __call__(self, q: np.ndarray) -> np.ndarray:
        self._forward_kinematics(self._model, self._data, q)
        return self._frame_placement(self._model, self._data, self._frame).rotation


class SamplePrior:
    """``InternalForcePrior`` -> the per-sample interface above (see the module docstring).

    Reads the columns of ``psmforce.identification.prior.arrays_from_frame``: the seven joint
    positions (gravity in the HEX10 frame and the shaft direction, through :class:`HexRotation`;
    roll and wrist pitch), the wrist efforts and the wrist velocities, then the insertion
    velocity and effort, and for a law with the sensor's cross-talk the HEX10's forces, which it
    reads. :meth:`predict_sample` returns the internal wrench (6) and :data:`INSERTION_FZ` (0
    without an insertion model).
    """

    input_columns = (JOINT_POSITIONS
                     + tuple(joint_column(j, "effort") for j in WRIST_JOINTS)
                     + tuple(joint_column(j, "velocity") for j in WRIST_JOINTS)
                     + (joint_column(INSERTION_JOINT, "velocity"),
                        joint_column(INSERTION_JOINT, "effort")))
    _ROLL, _WRIST_PITCH = JOINTS.index("roll"), JOINTS.index("wrist_pitch")

    def __init__(self, prior, psm=None):
        from psmforce.robot import PSM
        from psmforce.robot.conventions import GRAVITY_MPS2
        _check_reads_efforts(prior)
        self.prior, self.psm = prior, psm or PSM()
        self._rotation = HexRotation(self.psm)
        self._gravity = -GRAVITY_MPS2
        self._q = np.zeros(len(JOINT_POSITIONS))
        self._out = np.zeros(7)
        self._direction = prior.friction_state()  # carried sample by sample; None: not needed
        self._crosstalk = prior.has_crosstalk
        if self._crosstalk:
            self.input_columns = SamplePrior.input_columns + HEX10[:3]

    @property
    def insertion(self):
        return self.prior.insertion

    def predict(self, frame: pd.DataFrame) -> np.ndarray:
        return self.prior.predict(frame, self.psm)

    def insertion_axial_force(self, frame: pd.DataFrame) -> np.ndarray:
        return self.prior.insertion_axial_force(frame, self.psm)

    def predict_sample(self, values: np.ndarray) -> np.ndarray:
        n = len(JOINT_POSITIONS)
        self._q[:] = values[:n]
        rows = self._rotation(self._q).tolist()  # R_base_hex10 as Python floats, read twice
        # gravity (0, 0, -g) of the upright base, in the HEX10 frame: R^T e_z is R's third row
        g_hex = [x * self._gravity for x in rows[2]]
        v = values.tolist()
        z = (None if self._direction is None else
             self._direction.step(v[self._WRIST_PITCH], v[self._WRIST_PITCH + 1],
                                  v[self._WRIST_PITCH + 2]))
        wrench = self.prior.predict_one((v[self._ROLL], v[self._WRIST_PITCH]),
                                        v[n:n + 3], v[n + 3:n + 6], g_hex, z,
                                        v[n + 8:n + 11] if self._crosstalk else None)
        insertion = self.prior.insertion
        if insertion is None:
            self._out[:6] = wrench
        else:  # the shaft (HEX10 z) in the base frame: R's third column
            shaft = [rows[0][2], rows[1][2], rows[2][2]]
            self._out[:] = (*wrench, insertion.axial_force_one(shaft, v[n + 6], v[n + 7]))
        return self._out


def sample_prior(prior, psm=None):
    """``prior`` as it is when it has the per-sample interface, else wrapped in
    :class:`SamplePrior`."""
    if prior is None or (hasattr(prior, "predict_sample") and hasattr(prior, "input_columns")):
        return prior
    return SamplePrior(prior, psm)


class HybridInputs:
    """Raw recorded signals -> (scaled network inputs, base) in a model's column order.

    ``features`` / ``base_columns``: the checkpoint's columns; any of :data:`PRIOR_COLUMNS`
    among them is computed with ``prior``. :attr:`raw_columns` lists the recorded columns needed,
    in the order :meth:`sample` expects them.
    """

    def __init__(self, features: Sequence[str], base_columns: Sequence[str], input_scaler,
                 prior=None, extra_columns: Sequence[str] = (), psm=None, *,
                 physics_prior=None, physics_axes: Sequence[str] = ()):
        self.features, self.base_columns = tuple(features), tuple(base_columns)
        derived = set(PRIOR_COLUMNS)
        uses_prior = any(c in derived for c in self.features + self.base_columns)
        if uses_prior and prior is None:
            raise HybridInputError(f"columns {sorted(derived & set(self.features))} need a prior")
        self.prior = sample_prior(prior, psm) if uses_prior else None
        self._has_insertion = getattr(self.prior, "insertion", None) is not None
        if INSERTION_FZ in self.features + self.base_columns and not self._has_insertion:
            raise HybridInputError(f"column {INSERTION_FZ!r} needs a prior with an insertion model")
        if len(self.base_columns) not in (0, 3):
            raise HybridInputError(f"base needs 0 or 3 entries, got {list(self.base_columns)}")
        raw = [c for c in self.features + self.base_columns + tuple(extra_columns)
               if c not in derived and c != NO_BASE]
        if self.prior is not None:
            raw += list(HEX10) + list(self.prior.input_columns)
        self.physics_prior, self.physics_axes = None, tuple(physics_axes)
        """The prior of the physics-only axes' own (None: :attr:`prior` answers them too)."""
        if physics_prior is not None:
            why = physics_base_problem(self.base_columns, self.physics_axes)
            if why is not None:
                raise HybridInputError(why)
            self.physics_prior = sample_prior(physics_prior, psm)
            needed = [self.base_columns[AXES.index(a)] for a in self.physics_axes]
            if INSERTION_FZ in needed and getattr(self.physics_prior, "insertion", None) is None:
                raise HybridInputError(f"column {INSERTION_FZ!r} needs a prior with an "
                                       f"insertion model")
            raw += list(HEX10) + list(self.physics_prior.input_columns)
        self.raw_columns = tuple(dict.fromkeys(raw))
        source = self.raw_columns + PRIOR_COLUMNS + (NO_BASE,)  # the last slot stays 0
        self._feature_index = np.array([source.index(c) for c in self.features])
        self._base_index = np.array([source.index(c) for c in self.base_columns], dtype=np.intp)
        # the scaler's float32 values (the network's training), held as float64: exact, and the
        # arithmetic with them was float64 already; numpy's mixed-type loops cost more per sample
        self._mean = np.asarray(input_scaler.mean, np.float32).astype(np.float64)
        self._std = np.asarray(input_scaler.std, np.float32).astype(np.float64)
        if self._mean.shape != (len(self.features),):
            raise HybridInputError(f"input scaler has {self._mean.shape} entries for "
                                   f"{len(self.features)} features")
        n_raw = len(self.raw_columns)
        if self.prior is not None:
            self._hex10_index = np.array([self.raw_columns.index(c) for c in HEX10])
            self._prior_index = np.array([self.raw_columns.index(c)
                                          for c in self.prior.input_columns])
        self._source = np.zeros(len(source))
        self._raw_view = self._source[:n_raw]
        self._comp_view = self._source[n_raw:n_raw + 6]
        # PRIOR_COLUMNS after the compensated ones (prior_fz, insertion_fz, prior_fx, _fy, _tx,
        # _ty, _tz): the index of each in predict_sample's output (fx .. tz, insertion_fz), one
        # gather per sample; insertion_fz stays 0 without an insertion model
        outputs = (2, 6, 0, 1, 3, 4, 5)
        kept = [k for k, i in enumerate(outputs) if i != 6 or self._has_insertion]
        self._prior_slots = n_raw + 6 + np.array(kept)
        self._prior_order = np.array([outputs[k] for k in kept])
        if self.physics_prior is not None:
            # per physics-only axis: base = HEX10 entry - internal entry (a comp_* column) or
            # + the insertion entry (insertion_fz, output 6), one gather each per sample
            self._physics_index = np.array([self.raw_columns.index(c)
                                            for c in self.physics_prior.input_columns])
            self._physics_k = np.array([AXES.index(a) for a in self.physics_axes])
            cols = [self.base_columns[k] for k in self._physics_k]
            comp = [COMPENSATED_HEX10.index(c) if c != INSERTION_FZ else None for c in cols]
            self._physics_hex = np.array([self.raw_columns.index(HEX10[j]) if j is not None
                                          else 0 for j in comp])
            self._physics_hex_gain = np.array([0.0 if j is None else 1.0 for j in comp])
            self._physics_out = np.array([6 if j is None else j for j in comp])
            self._physics_sign = np.array([1.0 if j is None else -1.0 for j in comp])
        self._x64 = np.zeros(len(self.features))
        self.x = np.zeros(len(self.features), np.float32)
        self.base = np.zeros(len(self.base_columns))

    def frame(self, frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
        """Whole recording -> (scaled inputs (N, F) float32, base (N, len(base)) float64)."""
        missing = [c for c in self.raw_columns if c not in frame.columns]
        if missing:
            raise HybridInputError(f"recording lacks columns {missing}")
        cols = {c: frame[c].to_numpy(dtype=np.float64) for c in self.raw_columns}
        cols[NO_BASE] = np.zeros(len(frame))
        if self.prior is not None:
            cols.update(compensated_hex10(frame, self.prior))
        x = np.column_stack([cols[c] for c in self.features])
        x = ((x - self._mean) / self._std).astype(np.float32)
        base = (np.column_stack([cols[c] for c in self.base_columns]) if self.base_columns
                else np.zeros((len(frame), 0)))
        if self.physics_prior is not None:
            for k, column in physics_base(frame, self.physics_prior, self.base_columns,
                                          self.physics_axes).items():
                base[:, k] = column
        return x, base

    def sample(self, raw: np.ndarray) -> None:
        """One sample (``raw_columns`` order, finite) -> :attr:`x` (scaled) and :attr:`base`."""
        # gathers by fancy indexing (a new small array) are faster than np.take(..., out=),
        # which pays numpy's Python-level wrapper, at the sizes here; this runs at 1 kHz
        source = self._source
        self._raw_view[:] = raw
        if self.prior is not None:
            internal = self.prior.predict_sample(self._raw_view[self._prior_index])
            np.subtract(self._raw_view[self._hex10_index], internal[:6], out=self._comp_view)
            source[self._prior_slots] = internal[self._prior_order]
        np.subtract(source[self._feature_index], self._mean, out=self._x64)
        np.divide(self._x64, self._std, out=self._x64)
        self.x[:] = self._x64
        source.take(self._base_index, out=self.base)
        if self.physics_prior is not None:
            raw_view = self._raw_view
            internal = self.physics_prior.predict_sample(raw_view[self._physics_index])
            self.base[self._physics_k] = (self._physics_hex_gain * raw_view[self._physics_hex]
                                          + self._physics_sign * internal[self._physics_out])
