"""The trained-model record: what a model reads, its weights and where it came from, in one place.

:class:`TrainedModel` is a model's setup (recipe name and constructor config, input columns,
scalers, base columns, derivation, prior) before training, and with ``model`` and ``provenance``
filled in after it; it is what training, evaluation, finetuning, calibration, streaming and export
pass around, and what :meth:`TrainedModel.save` writes and :func:`load_checkpoint` reads. The export
JSON (:mod:`psmforce.estimators.runtime.export`) is written from the same
:meth:`TrainedModel.metadata`.

One file (``torch.save`` of plain tensors, strings and numbers; read back with
``weights_only=True``) holds: the weights; the model name and its constructor config; the input
columns in order; the input and target scalers; the base columns added to the output (residual
models); the inputs derivation (``"none"``, ``"lstm"`` for the Jacobian-map columns, ``"prior"`` for
the prior-compensated columns) with the prior as the JSON its ``save`` writes; software versions;
training provenance (data folder, split, seed, epochs, losses, wall time); for a model registered
outside :mod:`psmforce.estimators.networks.recipes`, the ``recipe``'s import path
(``"module:attribute"``, :func:`psmforce.estimators.networks.recipes.origin`), which loading never
imports: it only names the module in the refusal when the model is not registered
(:func:`psmforce.estimators.networks.recipes.require_recipe`). Writes are atomic (temporary
file, then rename).

Integrity (format version 3, :mod:`psmforce.core.integrity`): the metadata carries
``weights_sha256``, a SHA-256 over the weights (:func:`weights_sha256`: each tensor's name, dtype,
shape and bytes, in name order), ``prior_sha256`` over the prior's JSON, and the envelope ``sha256``
over every metadata field (feature order, scalers, base columns, derivation, model config,
provenance, versions, ``sample_rate_hz``, any field added later, and the two digests above). Loading
recomputes all of them: a swapped feature name, a collapsed scaler or a byte changed in the weights
is refused naming the file and the field, never loaded. The format version must be an ``int``:
``"3"``, ``3.0`` or ``true`` is refused, not coerced.

Older files are refused, each with the one line that says what to do. Version 2 (written before
the envelope; only the weights carry a checksum) cannot be told from a version 3 file whose
metadata was edited and relabelled, so loading it would let an edit through unseen: the refusal
names ``psmforce upgrade-checkpoint OLD --out NEW`` (:func:`upgrade_checkpoint`), which checks
all it can (the weights' checksum, the metadata's shape and sense) and seals what the file holds
as version 3: the user vouches for its content once, in a command, not silently at every load.
Version 1 (no checksum at all) is refused for good: nothing in it can be verified.

The metadata carries ``sample_rate_hz``, the rate the model was trained at
(:mod:`psmforce.estimators.data.rates`); a file without it (written before the field, or null) loads
as :data:`psmforce.estimators.data.rates.DEFAULT_SAMPLE_RATE_HZ` = 100 Hz, so a loaded record always
has a rate.

Loading refuses, with :class:`CheckpointError` naming the file and the problem in one line: an
empty, unreadable or corrupt file (a text file, a truncated one, weights or metadata not matching
their digests), a file of another format or format version, metadata of the wrong shape (features
not distinct names, scalers not finite with std > 0 of the right length, a base of other than 0 or 3
columns), a model name or config the code cannot build or that is outside its recipe's ranges
(:func:`psmforce.estimators.networks.recipes.check_config`, checked before anything is allocated),
and weights that do not fit the config. :meth:`TrainedModel.check_compatible` refuses a checkpoint
for a setup it was not trained for (another model, other features, a dataset lacking its input
columns).

:meth:`TrainedModel.save` also records in the provenance, where it names a data folder and its
training and validation trials, the SHA-256 of each of those recordings (``trial_sha256``), so a
test set repeating them is found by content
(:func:`psmforce.estimators.data.sanity.repeated_recordings`).

**Physics-only axes** (``physics_only_axes``, optional, absent = none; ``psmforce calibrate
--network-off``). A residual model's estimate is ``residual + base`` on every axis; on an axis
named here it is the base alone (the prior's estimate): the network's residual, its target
scaler's mean included, is not added there. It is for an axis the physics carries better than a
network that never saw it loaded (an ATI-free calibration, docs/ati_free.md section 4.5).
:func:`residual_gain` is the one definition evaluation, streaming and export apply. Allowed only
with 3 base columns (without a base the axis would read 0 N) and not for a network that
predicts its variance (its std describes the residual it would no longer add); names are of
:data:`psmforce.io.recording.AXES`.

**A prior of the physics-only axes' own** (``physics_prior_json``, optional, absent = none;
``psmforce calibrate --network-prior trained``): the base of the physics-only axes computed with
this prior instead of ``prior_json``, which the network's inputs (and the base of the axes it
answers) keep reading (:mod:`psmforce.estimators.data.hybrid_inputs`, "A prior of the
physics-only axes' own"). Stored beside the prior, with its own ``physics_prior_sha256`` in the
sealed metadata; allowed only with physics-only axes whose base columns a prior computes
(:func:`~psmforce.estimators.data.hybrid_inputs.physics_base_problem`), and parsed at load as
strictly as any prior.

Size: the record, its file and every check of what is read back from it, in one place, so that
what a checkpoint may hold is stated once.
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np
import torch

from psmforce.estimators.data.dataset import NO_BASE, Scaler
from psmforce.estimators.data.sanity import file_sha256
from psmforce.estimators.data.hybrid_inputs import physics_base_problem, prior_from_json
from psmforce.core.integrity import check_version, seal, sha256_bytes, verify
from psmforce.estimators.data.rates import DEFAULT_SAMPLE_RATE_HZ
from psmforce.estimators.networks.recipes import (DERIVATIONS, build_model, origin, recipe,
                                                  require_recipe)
from psmforce.core.files import MAX_DATA_BYTES, atomic_path, check_input_file
from psmforce.estimators.networks.uncertainty import predicts_variance
from psmforce.io.recording import AXES

FORMAT = "psmforce-checkpoint"
FORMAT_VERSION = 3
"""3: the integrity envelope over weights and metadata; 2: ``weights_sha256`` only (refused,
upgraded by :func:`upgrade_checkpoint`); 1: no checksum (refused)."""
_READABLE_VERSIONS = (3,)
_UPGRADABLE_VERSIONS = (2, 3)


class CheckpointError(ValueError):
    """A checkpoint that cannot be read, or does not fit the setup it is asked to serve."""


def residual_gain(physics_only_axes: Sequence[str] = ()) -> np.ndarray:
    """(3,) per axis of :data:`~psmforce.io.recording.AXES`: 1.0 where the network's un-scaled
    residual is added to the base, 0.0 on ``physics_only_axes`` (module docstring)."""
    return np.array([0.0 if a in physics_only_axes else 1.0 for a in AXES])


def physics_only_problem(physics_only_axes, base_columns: Sequence[str],
                         variance: bool) -> str | None:
    """Why ``physics_only_axes`` cannot be set on a model with these base columns (and a
    variance output or not), or None when it can (module docstring)."""
    axes = physics_only_axes
    if not isinstance(axes, (list, tuple)) or not all(isinstance(a, str) for a in axes):
        return f"physics_only_axes must be a list of axis names of {list(AXES)}, got {axes!r}"
    unknown = [a for a in axes if a not in AXES]
    if unknown or len(set(axes)) != len(axes):
        return (f"physics_only_axes must be distinct axis names of {list(AXES)}, got "
                f"{list(axes)}")
    if axes and len(base_columns) != 3:
        return (f"physics_only_axes {list(axes)} needs a residual model (3 base columns, the "
                f"physics it falls back to); this one has none")
    bare = [a for a in axes if base_columns[AXES.index(a)] == NO_BASE]
    if bare:
        return (f"physics_only_axes {bare}: no base column on that axis, so it would read 0 N")
    if axes and variance:
        return (f"physics_only_axes {list(axes)} is refused for a network that predicts its "
                f"variance: its std describes the residual those axes would not add")
    return None


@dataclass
class TrainedModel:
    """One model's setup, weights and provenance; see the module docstring."""

    model_name: str
    """A key of :data:`psmforce.estimators.networks.recipes.RECIPES`."""
    config: dict
    """The model constructor's keyword arguments."""
    features: tuple[str, ...]
    """Input columns, in the network's order."""
    input_scaler: Scaler
    target_scaler: Scaler
    base_columns: tuple[str, ...] = ()
    """Columns added to the output (a residual model); empty for none."""
    derivation: str = "none"
    """How the derived input columns are computed (:data:`psmforce.estimators.networks.recipes.DERIVATIONS`)."""
    prior_json: str | None = None
    """The internal-force prior as its JSON (derivation ``"prior"``), else None."""
    model: object | None = None
    """The trained model (None before training)."""
    provenance: dict = field(default_factory=dict)
    """Training data, configuration, losses, wall time; what it was finetuned or calibrated from."""
    versions: dict = field(default_factory=dict)
    """Software versions of the run that wrote the file."""
    sample_rate_hz: float | None = None
    """The rate (Hz) of the samples the model was trained on (:func:`psmforce.estimators.data.rates.trials_rate_hz`);
    None where unknown, written as null and read as :data:`psmforce.estimators.data.rates.DEFAULT_SAMPLE_RATE_HZ`."""
    physics_only_axes: tuple[str, ...] = ()
    """Axes (of :data:`~psmforce.io.recording.AXES`) whose estimate is the base alone, the
    network's residual not added (module docstring, "Physics-only axes")."""
    physics_prior_json: str | None = None
    """The prior of the physics-only axes' own as its JSON, else None: :attr:`prior_json`
    answers them too (module docstring)."""

    def residual_gain(self) -> np.ndarray:
        """(3,) 1.0 where the residual is added, 0.0 on :attr:`physics_only_axes`."""
        return residual_gain(self.physics_only_axes)

    @property
    def recipe(self):
        return recipe(self.model_name)

    def prior(self):
        """The internal-force prior (an ``InternalForcePrior``), or None without one."""
        return prior_from_json(self.prior_json) if self.prior_json else None

    def physics_prior(self):
        """The prior of the physics-only axes' own, or None (:attr:`physics_prior_json`)."""
        return prior_from_json(self.physics_prior_json) if self.physics_prior_json else None

    def derive(self, dataset) -> None:
        """Add the derived columns this model reads (Jacobian maps, prior columns) to every
        trial of ``dataset`` and refuse data that lacks its inputs."""
        DERIVATIONS[self.derivation](dataset, self.prior_json)
        for trial in dataset.trials:
            self.check_compatible(available_columns=list(trial.frame.columns))

    def metadata(self) -> dict:
        """The JSON-ready description of the setup (every field but the weights and the prior),
        shared by the checkpoint and the export."""
        return {"model": self.model_name, "config": self.config, "features": list(self.features),
                "input_scaler": self.input_scaler.to_dict(),
                "target_scaler": self.target_scaler.to_dict(),
                "base_columns": list(self.base_columns), "derivation": self.derivation,
                "sample_rate_hz": self.sample_rate_hz,
                "physics_only_axes": list(self.physics_only_axes),
                "versions": self.versions, "provenance": self.provenance,
                **({"recipe": home} if (home := origin(self.model_name)) else {})}

    def save(self, path: str | Path) -> Path:
        """Write the record (trained ``model`` required) to ``path`` atomically."""
        if self.model is None:
            raise CheckpointError(f"{path}: nothing to save, the '{self.model_name}' model is "
                                  f"not trained")
        path = Path(path)
        why = physics_only_problem(self.physics_only_axes, self.base_columns,
                                   predicts_variance(self.model))
        if why is None and self.physics_prior_json is not None:
            why = _physics_prior_problem(self.physics_prior_json, self.physics_only_axes,
                                         self.base_columns)
        if why is not None:
            raise CheckpointError(f"{path}: {why}")
        state = {k: v.detach().cpu() for k, v in self.model.state_dict().items()}
        if "trial_sha256" not in self.provenance:
            hashes = _hash_trials(self.provenance)
            if hashes:
                self.provenance = {**self.provenance, "trial_sha256": hashes}
        prior_json = self.prior_json or ""
        physics = ({"physics_prior_sha256": sha256_bytes(self.physics_prior_json.encode())}
                   if self.physics_prior_json is not None else {})
        meta = seal({"format": FORMAT, "format_version": FORMAT_VERSION, **self.metadata(),
                     "versions": _versions(), "weights_sha256": weights_sha256(state),
                     "prior_sha256": sha256_bytes(prior_json.encode()), **physics})
        payload = {"meta": json.dumps(meta), "prior_json": prior_json, "state_dict": state,
                   **({"physics_prior_json": self.physics_prior_json} if physics else {})}
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            torch.save(payload, tmp)
        return path

    def check_compatible(self, *, model_name: str | None = None,
                         features: Sequence[str] | None = None,
                         available_columns: Sequence[str] | None = None) -> None:
        """Raise :class:`CheckpointError` when the record does not fit the requested setup."""
        if model_name is not None and model_name != self.model_name:
            raise CheckpointError(f"checkpoint holds a '{self.model_name}' model, "
                                  f"the setup asks for '{model_name}'")
        if features is not None and tuple(features) != self.features:
            extra = sorted(set(features) - set(self.features))
            lacking = sorted(set(self.features) - set(features))
            raise CheckpointError(
                f"checkpoint was trained on {len(self.features)} input columns, the setup gives "
                f"{len(features)}" + (f"; not in checkpoint: {extra}" if extra else "")
                + (f"; missing from setup: {lacking}" if lacking else "")
                + ("" if extra or lacking else "; same columns in another order"))
        if available_columns is not None:
            missing = [c for c in self.features if c not in set(available_columns)]
            if missing:
                raise CheckpointError(f"the data lacks the checkpoint's input columns {missing}")


def _versions() -> dict:
    from importlib.metadata import PackageNotFoundError, version
    try:
        ours = version("psmforce")
    except PackageNotFoundError:
        ours = "unknown"
    return {"psmforce": ours, "torch": torch.__version__, "numpy": np.__version__,
            "python": platform.python_version()}


def trial_hashes(provenance: dict) -> dict:
    """Trial path -> SHA-256 of its file, for the trials a model was trained and validated on,
    as the provenance's ``trial_sha256`` records them (empty where it records none). Only what
    the file holds: no path the provenance names is read, since a file must not decide which
    files a command reads."""
    recorded = provenance.get("trial_sha256")
    if not isinstance(recorded, dict):
        return {}
    return {t: h for t, h in recorded.items() if isinstance(t, str) and isinstance(h, str)}


def _hash_trials(provenance: dict) -> dict:
    """Trial path -> SHA-256 of its file for the training and validation trials of a training
    that just ran (its ``data_dir``, the caller's dataset), read where the files are there."""
    if not isinstance(provenance.get("data_dir"), str):
        return {}
    names = [t for key in ("train_trials", "val_trials")
             for t in provenance.get(key, []) or [] if isinstance(t, str)]
    root = Path(provenance["data_dir"])
    return {t: file_sha256(root / t) for t in names if (root / t).is_file()}


def weights_sha256(state: dict) -> str:
    """SHA-256 hex digest of a state dict of tensors: name, dtype, shape and raw bytes of each,
    in name order (independent of the device and of how torch lays out the file)."""
    digest = hashlib.sha256()
    for name in sorted(state):
        tensor = state[name].detach().cpu().contiguous()
        digest.update(f"{name}|{tensor.dtype}|{tuple(tensor.shape)}|".encode())
        digest.update(tensor.reshape(-1).view(torch.uint8).numpy().tobytes())
    return digest.hexdigest()


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return f"{type(err).__name__}: {text.splitlines()[0][:200]}" if text else type(err).__name__


def load_checkpoint(path: str | Path, device: str = "cpu") -> TrainedModel:
    """The checkpoint at ``path``, every check of the module docstring passed, else
    :class:`CheckpointError` in one line naming the file."""
    return _load(Path(path), device, _READABLE_VERSIONS)


def upgrade_checkpoint(path: str | Path, out: str | Path) -> dict:
    """Seal the version 2 checkpoint at ``path`` as version 3 at ``out``: its weights' checksum
    and its metadata's shape and sense are checked as at any load, what cannot be checked (that
    the metadata is what training wrote) is vouched for by the caller. Returns a summary."""
    record = _load(Path(path), "cpu", _UPGRADABLE_VERSIONS)
    record.save(out)
    return {"checkpoint": str(out), "from": str(path), "model": record.model_name,
            "features": len(record.features),
            "trial_sha256": bool(trial_hashes(record.provenance))}


def _load(path: Path, device: str, versions: tuple[int, ...]) -> TrainedModel:
    if not path.exists():
        raise CheckpointError(f"checkpoint {path} does not exist")
    try:
        check_input_file(path, MAX_DATA_BYTES, "checkpoint")
    except ValueError as err:
        raise CheckpointError(str(err)) from None
    if path.stat().st_size == 0:
        raise CheckpointError(f"{path}: empty file, not a psmforce checkpoint")
    try:
        payload = torch.load(path, map_location=device, weights_only=True)
    except Exception as err:  # noqa: BLE001 - foreign bytes raise anything (text: KeyError)
        raise CheckpointError(f"{path}: corrupt or not a psmforce checkpoint "
                              f"({_first_line(err)})") from None
    try:
        meta = json.loads(payload["meta"])
        state = payload["state_dict"]
        prior_json = payload.get("prior_json", "")
        physics_prior_json = payload.get("physics_prior_json")
        version = meta.get("format_version")
    except (TypeError, KeyError, IndexError, AttributeError, json.JSONDecodeError):
        raise CheckpointError(f"{path}: not a psmforce checkpoint (no metadata)") from None
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a psmforce checkpoint (format {meta.get('format')!r})")
    if version == 1 and type(version) is int:  # noqa: E721 - True == 1
        raise CheckpointError(f"{path}: checkpoint format version 1 carries no checksum, so "
                              f"nothing in it can be verified; retrain it (this code reads "
                              f"versions {list(_READABLE_VERSIONS)})")
    if version == 2 and type(version) is int and 2 not in versions:  # noqa: E721
        raise CheckpointError(f"{path}: checkpoint format version 2 has no checksum over its "
                              f"metadata and prior, so an edit to them cannot be seen; if you "
                              f"trust this file, upgrade it once: psmforce upgrade-checkpoint "
                              f"{path} --out NEW.pt")
    check_version(version, versions, str(path), "checkpoint", CheckpointError)
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor)
                                              for v in state.values()):
        raise CheckpointError(f"{path}: corrupt checkpoint (weights are not a dict of tensors)")
    if weights_sha256(state) != meta.get("weights_sha256"):
        raise CheckpointError(f"{path}: corrupt checkpoint (the weights do not match their "
                              f"SHA-256 checksum)")
    if version >= 3:
        verify(meta, str(path), "checkpoint metadata", CheckpointError)
        if not isinstance(prior_json, str) \
                or sha256_bytes(prior_json.encode()) != meta.get("prior_sha256"):
            raise CheckpointError(f"{path}: corrupt checkpoint (the prior does not match its "
                                  f"SHA-256 checksum)")
        expected = meta.get("physics_prior_sha256")
        if (physics_prior_json is not None or expected is not None) and (
                not isinstance(physics_prior_json, str)
                or sha256_bytes(physics_prior_json.encode()) != expected):
            raise CheckpointError(f"{path}: corrupt checkpoint (the physics-only axes' prior "
                                  f"does not match its SHA-256 checksum)")
    _check_metadata(meta, path)
    rate = meta.get("sample_rate_hz")
    rate = DEFAULT_SAMPLE_RATE_HZ if rate is None else rate
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate < math.inf:
        raise CheckpointError(f"{path}: corrupt checkpoint (sample_rate_hz {rate!r} is not a "
                              f"rate in Hz)")
    features = tuple(meta["features"])
    try:  # the config is checked against its recipe's ranges before anything is allocated
        require_recipe(meta["model"], meta.get("recipe"))  # registered by the user, not the file
        model = build_model(meta["model"], len(features), meta["config"])
    except (TypeError, ValueError) as err:  # an unknown name (RecipeError) is a ValueError
        raise CheckpointError(f"{path}: cannot build model '{meta['model']}' with config "
                              f"{json.dumps(meta['config'])[:200]}: {err}") from None
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as err:
        raise CheckpointError(f"{path}: weights do not fit model '{meta['model']}' with "
                              f"{len(features)} inputs and config {meta['config']} "
                              f"({_first_line(err)})") from None
    physics_only = meta.get("physics_only_axes", [])
    why = physics_only_problem(physics_only, meta["base_columns"], predicts_variance(model))
    if why is None and physics_prior_json is not None:
        why = _physics_prior_problem(physics_prior_json, physics_only, meta["base_columns"])
    if why is not None:
        raise CheckpointError(f"{path}: corrupt checkpoint ({why})")
    model.to(device).eval()
    return TrainedModel(meta["model"], meta["config"], features,
                        Scaler.from_dict(meta["input_scaler"]),
                        Scaler.from_dict(meta["target_scaler"]), tuple(meta["base_columns"]),
                        meta["derivation"], prior_json or None, model,
                        meta.get("provenance", {}), meta.get("versions", {}), float(rate),
                        tuple(physics_only), physics_prior_json)


def _physics_prior_problem(text: str, physics_only_axes, base_columns) -> str | None:
    """Why ``text`` cannot be a checkpoint's prior of the physics-only axes' own (module
    docstring), or None: the axes' base must come from a prior, and the JSON must read as one."""
    why = physics_base_problem(base_columns, physics_only_axes)
    if why is not None:
        return why
    try:
        prior_from_json(text)
    except ValueError as err:  # the strict loading of any prior (IdentificationInputError)
        return f"the physics-only axes' prior does not read as a prior ({_first_line(err)})"
    return None


def _check_metadata(meta: dict, path: Path) -> None:
    """The metadata's shape and sense, whatever its version: what loading would otherwise pass
    on to a model that scores garbage (or divides by a zero std)."""
    def bad(text: str) -> CheckpointError:
        return CheckpointError(f"{path}: corrupt checkpoint ({text})")
    missing = [k for k in ("model", "config", "features", "input_scaler", "target_scaler",
                           "base_columns", "derivation") if k not in meta]
    if missing:
        raise bad(f"metadata lacks {missing}")
    if meta["derivation"] not in DERIVATIONS:
        raise CheckpointError(f"{path}: unknown input derivation {meta['derivation']!r}; this "
                              f"code knows {list(DERIVATIONS)}")
    features = meta["features"]
    if not isinstance(features, list) or not features or not all(
            isinstance(f, str) and f for f in features) or len(set(features)) != len(features):
        raise bad("features must be distinct column names")
    base = meta["base_columns"]
    if not isinstance(base, list) or len(base) not in (0, 3) or not all(
            isinstance(c, str) for c in base):
        raise bad("base_columns must be 0 or 3 column names")
    if not isinstance(meta["model"], str) or not isinstance(meta["config"], dict):
        raise bad("model must be a name and config an object")
    if not isinstance(meta.get("provenance", {}), dict):
        raise bad("provenance must be an object")
    for key, width in (("input_scaler", len(features)), ("target_scaler", 3)):
        scaler = meta[key]
        try:
            mean, std = (np.asarray(scaler[k], dtype=np.float64) for k in ("mean", "std"))
        except (TypeError, KeyError, ValueError, IndexError):
            raise bad(f"{key} must hold 'mean' and 'std' number lists") from None
        if mean.shape != (width,) or std.shape != (width,):
            raise bad(f"{key} must hold {width} means and stds, got {mean.shape} and "
                      f"{std.shape}")
        with np.errstate(over="ignore"):  # checked in float32, the dtype the scaler is used in
            mean, std = mean.astype(np.float32), std.astype(np.float32)
        if not (np.isfinite(mean).all() and np.isfinite(std).all()
                and (std >= Scaler.MIN_STD).all()):
            raise bad(f"{key} must be finite with std >= {Scaler.MIN_STD:g} in float32, the "
                      f"dtype it is used in")
