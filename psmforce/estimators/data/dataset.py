"""Recordings -> model-ready arrays: loading, feature sets, the paper's split, scaling, windows.

A dataset is a folder of recording CSVs (layout and units: :mod:`psmforce.io.recording`) with a
``metadata.json`` whose ``trials`` list gives each file's path, condition and split. The simulator
writes it last, so a folder without it is an interrupted or foreign one and is refused: a dataset
is read whole or not at all. A folder of your own recordings becomes a dataset explicitly with
:func:`index_recordings` (``psmforce index DIR``): condition = each file's parent folder (Free,
Traction, Palpation, Rigid, Soft), split = the grandparent (train, test, config_k, ...).

Splits (seed paper, "Training and Testing Data Split"): the test trials are fixed by the dataset;
validation is ~10 % of the training trials, drawn per condition with a seed; free-space training
and validation data are down-sampled to 25 % by taking their windows 4x sparser
(:data:`FREE_STRIDE_FACTOR`; the paper's stride 20 instead of 5 for free-space files).

With ``require_targets`` (training, scoring) a recording whose ATI target column is constant
(all zeros: an unplugged sensor; a real one always reads noise) is refused by file and column;
train/test overlap by content: :mod:`psmforce.estimators.data.sanity`.

Windows are views, never per-window copies: :func:`sliding_windows` over one array, and
:class:`WindowSet` over all trials of a split concatenated once; a batch gathers its windows from
the view in one indexing call. Scalers are fitted on training data only.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from psmforce.estimators.data.bounds import physical_bounds
from psmforce.estimators.data.sanity import (entry_problem, outside_physical_range,
                                             target_problem)
from psmforce.io.recording import (HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES,
                                 PAPER_FEATURES, TARGETS, list_recordings, read_recording)

FREE_STRIDE_FACTOR = 4
"""Free-space trials are windowed this many times sparser in train/val (25 % down-sampling)."""

_POSITIONS = set(JOINT_POSITIONS)
_VELOCITIES = set(JOINT_VELOCITIES)
_EFFORTS = set(JOINT_EFFORTS)
_HEX10 = set(HEX10)


def _without(drop: set[str]) -> tuple[str, ...]:
    return tuple(c for c in PAPER_FEATURES if c not in drop)


FEATURE_SETS: dict[str, tuple[str, ...]] = {
    "paper": PAPER_FEATURES,
    "no_hex10": _without(_HEX10),
    "no_efforts": _without(_EFFORTS),
    "no_positions": _without(_POSITIONS),
    "no_velocities": _without(_VELOCITIES),
    "no_positions_velocities": _without(_POSITIONS | _VELOCITIES),
}
"""The paper's 21 inputs and its input ablations (seed paper, "Model Input Ablations")."""

class DatasetError(ValueError):
    """A dataset folder or a request on it that cannot be served; the message says why."""


def resolve_features(features: str | Sequence[str]) -> tuple[str, ...]:
    """A feature-set name from :data:`FEATURE_SETS`, or an explicit column list."""
    if isinstance(features, str):
        if features not in FEATURE_SETS:
            raise DatasetError(f"unknown feature set '{features}'; known: "
                               f"{sorted(FEATURE_SETS)} or an explicit column list")
        return FEATURE_SETS[features]
    cols = tuple(features)
    if not cols or len(set(cols)) != len(cols):
        raise DatasetError(f"feature list must be non-empty without repeats, got {list(cols)}")
    return cols


@dataclass
class Trial:
    """One recording: its table (columns of :mod:`psmforce.io.recording` plus any derived ones)."""

    path: str
    condition: str
    split: str
    frame: pd.DataFrame
    params: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.frame)

    def matrix(self, columns: Sequence[str], dtype=np.float32) -> np.ndarray:
        missing = [c for c in columns if c not in self.frame.columns]
        if missing:
            raise DatasetError(f"{self.path}: lacks columns {missing}")
        return self.frame[list(columns)].to_numpy(dtype=dtype)


@dataclass
class Dataset:
    root: Path
    trials: list[Trial]
    metadata: dict

    def select(self, *, split: str | Sequence[str] | None = None,
               condition: str | Sequence[str] | None = None) -> list[Trial]:
        splits = {split} if isinstance(split, str) else (set(split) if split else None)
        conds = ({condition} if isinstance(condition, str)
                 else (set(condition) if condition else None))
        return [t for t in self.trials if (splits is None or t.split in splits)
                and (conds is None or t.condition in conds)]

    def add_columns(self, derive: Callable[[Trial], dict[str, np.ndarray]]) -> None:
        """Append derived per-sample columns (prior predictions, Jacobian maps) to every trial."""
        for trial in self.trials:
            new = derive(trial)
            for name, values in new.items():
                if len(values) != len(trial):
                    raise DatasetError(f"{trial.path}: derived column '{name}' has {len(values)} "
                                       f"rows, the recording {len(trial)}")
            trial.frame = pd.concat([trial.frame.drop(columns=list(new), errors="ignore"),
                                     pd.DataFrame(new, index=trial.frame.index)], axis=1)


METADATA = "metadata.json"


def load_dataset(root: str | Path, *, require_targets: bool = True, threads: int = 2) -> Dataset:
    """Read every recording listed in ``root/metadata.json`` (module docstring). Raises
    :class:`DatasetError` naming the folder or file: a missing folder, no or unreadable
    metadata, an empty or malformed ``trials`` list, a value outside its physical range; passes
    on :class:`psmforce.io.recording.RecordingError` naming a bad recording."""
    root = Path(root)
    if not root.is_dir():
        raise DatasetError(f"dataset folder {root} " + ("is a file, not a folder" if root.exists()
                                                         else "does not exist"))
    meta_path = root / METADATA
    if not meta_path.is_file():
        raise DatasetError(f"{root}: no {METADATA}, so not a complete dataset (an interrupted "
                           f"simulate leaves none); for a folder of your own recordings run "
                           f"'psmforce index {root}' first")
    try:
        metadata = json.loads(meta_path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise DatasetError(f"{meta_path}: not valid JSON ({err})") from None
    entries = metadata.get("trials") if isinstance(metadata, dict) else None
    if not isinstance(entries, list) or not entries:
        raise DatasetError(f"{meta_path}: needs a non-empty 'trials' list (one entry per "
                           f"recording: path, condition, split)")
    listed = []
    for k, e in enumerate(entries):
        if not isinstance(e, dict) or not all(isinstance(e.get(f), str)
                                              for f in ("path", "condition", "split")):
            raise DatasetError(f"{meta_path}: trial entry {k} needs string fields 'path', "
                               f"'condition' and 'split', got {e!r:.200}")
        if Path(e["path"]).is_absolute() or ".." in Path(e["path"]).parts:
            raise DatasetError(f"{meta_path}: trial entry {k} path {e['path']!r} must be "
                               f"relative and inside {root}")
        listed.append((e["path"], e["condition"], e["split"], e))
    problem = entry_problem([(rel, condition, split) for rel, condition, split, _ in listed])
    if problem:
        raise DatasetError(f"{meta_path}: {problem}")

    bounds = physical_bounds()

    def read(item):
        rel, condition, split, extra = item
        frame = read_recording(root / rel, require_targets=require_targets)
        problem = (outside_physical_range(frame, bounds)
                   or (target_problem(frame) if require_targets else None))
        if problem:
            raise DatasetError(f"{root / rel}: {problem}")
        params = {k: v for k, v in extra.items() if k not in ("path", "condition", "split")}
        return Trial(str(rel), str(condition), str(split), frame, params)

    with ThreadPoolExecutor(max_workers=max(1, threads)) as pool:
        trials = list(pool.map(read, listed))
    return Dataset(root, trials, metadata)


def index_recordings(root: str | Path) -> Path:
    """Make a folder of recordings a dataset: write ``root/metadata.json`` listing every CSV
    under it, condition and split from its folders (module docstring). Refuses a folder that
    already has one (it may hold a simulator's parameters). Returns the metadata path."""
    from psmforce.core.files import write_text_atomic
    root = Path(root)
    meta_path = root / METADATA
    if root.is_file():
        raise DatasetError(f"{root}: a dataset is a folder of recordings, not one file")
    if meta_path.exists():
        raise DatasetError(f"{meta_path} exists: the folder is already a dataset")
    listed = list_recordings(root)  # refuses a missing folder or one without CSVs
    problem = entry_problem([(r.path.relative_to(root).as_posix(), r.condition, r.split)
                             for r in listed])
    if problem:
        raise DatasetError(f"{root}: {problem}")
    trials = [{"path": r.path.relative_to(root).as_posix(), "condition": r.condition,
               "split": r.split} for r in listed]
    write_text_atomic(meta_path, json.dumps(
        {"source": "psmforce index: condition = parent folder, split = its parent",
         "trials": trials}, indent=1) + "\n")
    return meta_path


def trajectory_group(trial: Trial) -> str:
    """The trajectory family a trial belongs to: its metadata ``group`` (the simulator names one
    per trajectory: a free-space replay shares its group with the trials it replays), else the
    trial itself."""
    return str(trial.params.get("group", trial.path))


def split_validation(trials: Sequence[Trial], fraction: float = 0.1,
                     seed: int = 0) -> tuple[list[Trial], list[Trial]]:
    """(train, validation), drawn with ``seed``, so that validation measures generalisation to
    unseen trajectories: whole trajectory families (:func:`trajectory_group`) go to validation,
    ``fraction`` of the families of each condition (rounded, at least one where a condition has
    two or more); a family's condition is that of its non-free-space trials (free space alone
    when it has none)."""
    if not 0 <= fraction < 1:
        raise DatasetError(f"validation fraction must be in [0, 1), got {fraction}")
    rng = np.random.default_rng(seed)
    members: dict[str, list[Trial]] = {}
    for t in trials:
        members.setdefault(trajectory_group(t), []).append(t)
    family_condition = {g: min((t.condition for t in ts if t.condition != "Free"),
                               default="Free") for g, ts in members.items()}
    chosen: set[str] = set()
    for cond in sorted(set(family_condition.values())):
        pool = sorted(g for g, c in family_condition.items() if c == cond)
        n_val = int(round(fraction * len(pool)))
        if fraction > 0 and len(pool) >= 2:
            n_val = max(n_val, 1)
        chosen |= {pool[i] for i in rng.permutation(len(pool))[:n_val]}
    train = [t for t in trials if trajectory_group(t) not in chosen]
    val = [t for t in trials if trajectory_group(t) in chosen]
    return train, val


def subsample_trials(trials: Sequence[Trial], fraction: float, seed: int = 0) -> list[Trial]:
    """A seeded ``fraction`` of the trials of each condition (at least one each): the
    data-efficiency runs train on fewer recordings, not on thinned windows."""
    if not 0 < fraction <= 1:
        raise DatasetError(f"training fraction must be in (0, 1], got {fraction}")
    rng = np.random.default_rng(seed)
    kept = []
    for cond in sorted({t.condition for t in trials}):
        group = [t for t in trials if t.condition == cond]
        n = max(1, int(round(fraction * len(group))))
        idx = sorted(rng.permutation(len(group))[:n].tolist())
        kept += [group[i] for i in idx]
    return kept


@dataclass
class Scaler:
    """Per-column standard scaling ``(x - mean) / std`` fitted on training data only."""

    mean: np.ndarray
    std: np.ndarray

    MIN_STD = 1e-9
    """The smallest std a column keeps (below: constant, std 1); files are checked in float32."""

    @classmethod
    def fit(cls, values: np.ndarray, raw: Sequence[bool] | None = None) -> "Scaler":
        """Columns flagged in ``raw`` are passed through (mean 0, std 1); constant columns keep
        std 1 so they are centred, not divided by zero."""
        values = np.asarray(values, dtype=np.float64)
        mean, std = values.mean(axis=0), values.std(axis=0)
        std = np.where(std > cls.MIN_STD, std, 1.0)
        if raw is not None:
            raw = np.asarray(raw, dtype=bool)
            mean, std = np.where(raw, 0.0, mean), np.where(raw, 1.0, std)
        return cls(mean.astype(np.float32), std.astype(np.float32))

    def transform(self, values: np.ndarray) -> np.ndarray:
        return ((values - self.mean) / self.std).astype(np.float32)

    def inverse(self, values):
        if isinstance(values, torch.Tensor):
            return values * torch.as_tensor(self.std, device=values.device) + torch.as_tensor(
                self.mean, device=values.device)
        return values * self.std + self.mean

    def to_dict(self) -> dict:
        return {"mean": self.mean.tolist(), "std": self.std.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> "Scaler":
        return cls(np.asarray(d["mean"], np.float32), np.asarray(d["std"], np.float32))


NO_BASE = ""
"""A base entry for an axis on which the network's output is the force itself (no base added)."""


def base_matrix(trial: Trial, base_columns: Sequence[str]) -> np.ndarray:
    """The (N, 3) base added to a residual model's output: per axis the trial's column, or zeros
    where the entry is :data:`NO_BASE`."""
    if len(base_columns) != 3:
        raise DatasetError(f"base needs 3 entries (x, y, z), got {list(base_columns)}")
    used = [c for c in base_columns if c != NO_BASE]
    out = np.zeros((len(trial), 3))
    out[:, [k for k, c in enumerate(base_columns) if c != NO_BASE]] = trial.matrix(used, np.float64)
    return out


def target_matrix(trial: Trial, base_columns: Sequence[str] = (), dtype=np.float32) -> np.ndarray:
    """The (N, 3) training target: the ATI force in the HEX10 frame, minus the base
    (:func:`base_matrix`) when ``base_columns`` are given (a residual target; the model's output is
    added to the base)."""
    y = trial.matrix(TARGETS, np.float64)
    if base_columns:
        y = y - base_matrix(trial, base_columns)
    return y.astype(dtype)


def fit_scalers(trials: Sequence[Trial], features: Sequence[str], raw_columns: Sequence[str] = (),
                base_columns: Sequence[str] = ()) -> tuple[Scaler, Scaler]:
    """(input scaler, target scaler) from the given (training) trials."""
    if not trials:
        raise DatasetError("cannot fit scalers on an empty training set")
    x = np.concatenate([t.matrix(features, np.float64) for t in trials])
    y = np.concatenate([target_matrix(t, base_columns, np.float64) for t in trials])
    return Scaler.fit(x, raw=[c in set(raw_columns) for c in features]), Scaler.fit(y)


def sliding_windows(values: np.ndarray, window: int, stride: int = 1) -> np.ndarray:
    """Zero-copy (n_windows, window, F) view of the windows of ``values`` (N, F) that start every
    ``stride`` samples: window k covers rows [k*stride, k*stride + window)."""
    if window < 1 or stride < 1:
        raise DatasetError(f"window and stride must be >= 1, got {window}, {stride}")
    if len(values) < window:
        return np.empty((0, window) + values.shape[1:], dtype=values.dtype)
    view = np.lib.stride_tricks.sliding_window_view(values, window, axis=0)[::stride]
    return np.moveaxis(view, -1, 1)


class WindowSet:
    """Every window of a list of trials, without copying a window.

    The trials' scaled inputs and targets are concatenated once into (N, F) / (N, 3) tensors and
    ``inputs.unfold`` gives a (N - L + 1, L, F) view of all windows; :attr:`starts` lists the
    windows that lie inside one trial, ``stride`` apart (``stride * FREE_STRIDE_FACTOR`` for
    Free trials when ``downsample_free``). ``targets="last"`` pairs each window with the target of
    its last sample (window models); ``"all"`` with all of its targets (chunk models). Targets
    are residuals when ``base_columns`` are given (:func:`target_matrix`).
    """

    def __init__(self, trials: Sequence[Trial], features: Sequence[str], input_scaler: Scaler,
                 target_scaler: Scaler, window: int, stride: int, *, targets: str = "last",
                 downsample_free: bool = False, base_columns: Sequence[str] = ()):
        if targets not in ("last", "all"):
            raise DatasetError(f"targets must be 'last' or 'all', got '{targets}'")
        if not trials:
            raise DatasetError("no trials to window")
        self.window, self.stride, self.mode = window, stride, targets
        xs, ys, starts, offset = [], [], [], 0
        for t in trials:
            xs.append(input_scaler.transform(t.matrix(features)))
            ys.append(target_scaler.transform(target_matrix(t, base_columns)))
            step = stride * (FREE_STRIDE_FACTOR if downsample_free and t.condition == "Free" else 1)
            starts.append(offset + np.arange(0, len(t) - window + 1, step))
            offset += len(t)
        self.inputs = torch.from_numpy(np.concatenate(xs))
        self.targets = torch.from_numpy(np.concatenate(ys))
        self.starts = torch.from_numpy(np.concatenate(starts).astype(np.int64))
        if len(self.starts) == 0:
            raise DatasetError(f"no trial is as long as the window ({window} samples)")
        self._x_view = self.inputs.unfold(0, window, 1).transpose(1, 2)
        self._y_view = self.targets.unfold(0, window, 1).transpose(1, 2)

    def __len__(self) -> int:
        return len(self.starts)

    def batch(self, index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(x (B, L, F), y (B, 3) or (B, L, 3)) for the windows ``index`` into :attr:`starts`."""
        s = self.starts[index]
        x = self._x_view[s]
        y = self.targets[s + self.window - 1] if self.mode == "last" else self._y_view[s]
        return x, y
