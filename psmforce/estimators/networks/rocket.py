"""MultiRocket-Hydra baseline: random-convolution features + ridge regression, no training loop.

What: aeon's MultiRocket transform (84 fixed kernels at several dilations over the series and its
first difference, random channel subsets, four pooling operators) and Hydra transform (counts of
competing random kernels over the series and its first difference) turn each (L, F) window into
one feature vector. The two blocks are concatenated and standardised as aeon's
``MultiRocketHydraRegressor`` does it, and one ridge regression maps them to the three force axes
of the window's last sample, one penalty from :data:`ALPHAS` shared by the three axes. The
penalty is chosen on validation windows when the caller gives them (held-out trials, as the
other models' early stopping uses), else by exact leave-one-out error (the criterion of
sklearn's ``RidgeCV``, which aeon uses). Leave-one-out is optimistic on overlapping windows (a
left-out window's neighbours share most of its samples), so it picks too small a penalty: on
synthetic AR(1) trials with stride-1 windows it chose 10 where held-out trials scored best at
1e3-1e4. Pass validation windows from other trials.

Why: a standard non-deep time-series regressor, fitted in closed form (one transform, one
eigendecomposition), so it needs no learning rate, epochs or early stopping, and is deterministic
given its seed and thread count. It is a window model like the paper's transformer: standard-scaled
(B, L, F) windows -> (B, 3) standard-scaled targets (``kind = "window"``); it is not a torch module
but a :class:`psmforce.estimators.networks.contract.ClosedFormModel`, so
:mod:`psmforce.estimators.training.train`'s loop does not apply to it.

Bounded cost: training windows are subsampled with the seed to ``max_train_windows``; features
are computed, standardised and multiplied in batches; the ridge keeps the feature matrix in
float32 and only p x p arrays in float64. A fitted model saves as plain tensors
(:meth:`state_dict`: MultiRocket's dilations, biases and channel choices, Hydra's kernels, the
scaling and the ridge), so a checkpoint holding one stays free of pickled code;
:meth:`load_state_dict` rebuilds aeon's transforms around them.

aeon (with numba and scikit-learn) is imported only when fitting or loading, so this module
imports without it. numba compiles MultiRocket's kernels on first use (~40 s, once per
environment: aeon caches them on disk).

Size: one model. The transforms' batched standardisation, the ridge with its penalty choice and
the tensor-only state are private to it and exist only for it.
"""

from __future__ import annotations

import contextlib
import time
import warnings
from dataclasses import dataclass

import numpy as np
import torch

ALPHAS = np.logspace(-3, 6, 19)
"""Ridge penalties tried, half a decade apart: aeon's MultiRocketHydraRegressor's range
(1e-3-1e3) extended to 1e6, since with thousands of overlapping windows the best held-out
penalty lay at or above 1e3 in every synthetic check (features are standardised, so the penalty
is comparable to the number of windows)."""

DEFAULT_MAX_TRAIN_WINDOWS = 20_000
"""Training windows kept (seeded subsample). Measured with the default kernels (5,056 features)
on 21 channels x 100 samples, one thread of a 2-core machine whose other core ran a training:
features at ~650 windows/s (MultiRocket ~1,000/s and Hydra ~1,850/s alone; down to ~250/s when
both cores were contended); 20,000 windows plus 4,000 validation windows fit in 100-150 s, of
which the ridge 36 s (leave-one-out instead: ~55 s); the feature matrix is 0.4 GB of float32, the
fit's numpy allocations peak at 1.0 GB and the process at 2.3 GB with the data and libraries
loaded. 30,000 windows: 160 s, process peak 2.7 GB."""

MAX_FEATURES = 10_000
"""The ridge eigendecomposes the p x p Gram matrix: two float64 p x p arrays (1.6 GB at this
bound) and time growing as p^3 (~20 s on one core at the default 5,056 features, whatever the
number of windows). Larger kernel counts are refused."""

HYDRA_KERNELS_PER_GROUP = 8
"""aeon's Hydra default: kernels compete within groups of this size."""

_HYDRA_BATCH = 256
"""Windows per Hydra call: its grouped convolutions run ~15 % faster than in batches of 1,024."""

_MULTIROCKET_ARRAYS = 5
"""aeon's fitted MultiRocket holds per input (series, difference) a tuple of 5 arrays: channels
per kernel, channel indices, dilations, features per dilation, biases."""

_ROW_BLOCK = 4096
"""Rows per block of the float64 work in the ridge and the column statistics (~165 MB each)."""


@contextlib.contextmanager
def _threads(n: int):
    """BLAS, torch and OpenMP limited to ``n`` threads (MultiRocket's numba threads follow its
    ``n_jobs``); the caller's torch thread count is restored (Hydra's fit sets it globally).

    numba's parallel kernels run on its ``workqueue`` layer unless the user chose one
    (``NUMBA_THREADING_LAYER``): its default here is OpenMP through a second libgomp beside
    torch's, and once that pool had run, torch's attention in the same process was about 85x
    slower for the rest of its life (``benchmarks/process_interference.py``), which stalled every
    run that scores a paper transformer after MultiRocket-Hydra."""
    import numba
    from threadpoolctl import threadpool_limits  # comes with aeon, imported lazily like it
    if numba.config.THREADING_LAYER == "default":
        numba.config.THREADING_LAYER = "workqueue"
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        with threadpool_limits(n):
            yield
    finally:
        torch.set_num_threads(before)


@contextlib.contextmanager
def _own_global_rngs():
    """aeon seeds numpy's and torch's global generators when fitting (``np.random.seed``,
    ``torch.manual_seed``); the caller's streams are left as they were."""
    state = np.random.get_state()
    with torch.random.fork_rng(devices=[]):
        try:
            yield
        finally:
            np.random.set_state(state)


def _raw_features(multirocket, hydra, x: np.ndarray) -> np.ndarray:
    """(b, F, L) float32 windows in aeon's layout -> (b, p) float32: Hydra's counts
    square-rooted (the stateless half of aeon's Hydra scaling), then MultiRocket's features.
    aeon warns about windows with a constant channel (a joint held still for 1 s is normal
    here, and the standardised features handle it): that warning is silenced."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*very little variation", category=UserWarning)
        counts = np.concatenate([hydra.transform(x[i:i + _HYDRA_BATCH])
                                 for i in range(0, len(x), _HYDRA_BATCH)])
        np.sqrt(np.maximum(counts, 0.0, out=counts), out=counts)
        return np.concatenate([counts, multirocket.transform(x)], axis=1)


def _scaling(features: np.ndarray, n_hydra: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-column (offset, scale) of aeon's MultiRocketHydraRegressor: Hydra columns by their
    mean and std (n - 1) + zero_fraction^4 + 1e-8, MultiRocket columns by mean and std, a
    constant column keeping scale 1."""
    n, p = features.shape
    mean = features.mean(axis=0, dtype=np.float64)
    sq_dev, zeros = np.zeros(p), np.zeros(n_hydra)
    for i in range(0, n, _ROW_BLOCK):
        dev = features[i:i + _ROW_BLOCK] - mean
        sq_dev += np.einsum("ij,ij->j", dev, dev)
        zeros += np.count_nonzero(features[i:i + _ROW_BLOCK, :n_hydra] == 0, axis=0)
    hydra_std = np.sqrt(sq_dev[:n_hydra] / max(n - 1, 1))
    mr_std = np.sqrt(sq_dev[n_hydra:] / n)
    scale = np.concatenate([hydra_std + (zeros / n) ** 4 + 1e-8,
                            np.where(mr_std > 1e-9, mr_std, 1.0)])
    return mean.astype(np.float32), scale.astype(np.float32)


def _standardise(block: np.ndarray, offset: np.ndarray, scale: np.ndarray, n_hydra: int) -> None:
    """In place; a Hydra count of zero stays zero (aeon's sparse scaling: no match is no match)."""
    silent = block[:, :n_hydra] == 0
    block -= offset
    block /= scale
    block[:, :n_hydra][silent] = 0.0


def _feature_matrix(multirocket, hydra, x: np.ndarray) -> np.ndarray:
    """(n, p) float32 raw features of (n, F, L) windows, built :data:`_ROW_BLOCK` rows at a
    time; refuses more than :data:`MAX_FEATURES` columns before allocating."""
    first = _raw_features(multirocket, hydra, x[:_ROW_BLOCK])
    if first.shape[1] > MAX_FEATURES:
        raise ValueError(f"{first.shape[1]} features exceed MAX_FEATURES ({MAX_FEATURES}): lower "
                         f"n_kernels_multirocket or n_kernels_hydra")
    out = np.empty((len(x), first.shape[1]), dtype=np.float32)
    out[:len(first)] = first
    for i in range(_ROW_BLOCK, len(x), _ROW_BLOCK):
        out[i:i + _ROW_BLOCK] = _raw_features(multirocket, hydra, x[i:i + _ROW_BLOCK])
    return out


def _ridge(features: np.ndarray, targets: np.ndarray, alphas: np.ndarray = ALPHAS,
           validation: tuple[np.ndarray, np.ndarray] | None = None
           ) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """Ridge regression with an intercept on ``features`` (n, p) float32 and ``targets`` (n, k),
    one penalty for all targets: the first minimum of the mean squared error over samples and
    targets, on ``validation`` = (features, targets) when given, else leave-one-out (exact, as
    sklearn's ``RidgeCV`` computes it by default). Returns (coef (p, k) float64, intercept (k,),
    index of the chosen alpha, that error per alpha).

    With X centred, G = X^T X = V diag(lam) V^T and Z = X V: fitted centred targets
    Z diag(1 / (lam + a)) Z^T Y, hat diagonal h = (Z * Z) @ (1 / (lam + a)) + 1 / n (the
    intercept's share), leave-one-out residual = residual / (1 - h), coef = V diag(1 / (lam + a))
    Z^T Y for every alpha at once; validation rows, centred with the training means, meet those
    coefficients directly. Z is formed in row blocks, so the cost is ~3 n p^2 + one p x p
    eigendecomposition (~n p^2 + that with validation) and the memory two p x p float64 arrays
    beyond the features. sklearn's RidgeCV upcasts the features to float64, centres a copy and
    forms an n x p product per alpha: on 20,000 x 5,000 features, 148 s and 4.8 GB against 55 s
    and 1.7 GB here (leave-one-out, one thread).
    """
    n, p = features.shape
    x_mean = features.mean(axis=0, dtype=np.float64)
    y_mean = np.asarray(targets, dtype=np.float64).mean(axis=0)

    def centred(x: np.ndarray, i: int) -> np.ndarray:
        block = x[i:i + _ROW_BLOCK].astype(np.float64)
        block -= x_mean
        return block

    centred_y = np.asarray(targets, dtype=np.float64) - y_mean
    gram, xty = np.zeros((p, p)), np.zeros((p, centred_y.shape[1]))
    for i in range(0, n, _ROW_BLOCK):
        block = centred(features, i)
        gram += block.T @ block
        xty += block.T @ centred_y[i:i + _ROW_BLOCK]
    lam, vecs = np.linalg.eigh(gram)
    del gram
    lam = np.maximum(lam, 0.0)  # round-off can leave tiny negative eigenvalues
    zty = vecs.T @ xty
    inverse = 1.0 / (lam[:, None] + alphas[None, :])  # (p, A)
    coefs = vecs @ (zty[:, :, None] * inverse[:, None, :]).reshape(p, -1)  # (p, k * A)

    scored_x, scored_y = (features, centred_y) if validation is None else (
        validation[0], np.asarray(validation[1], dtype=np.float64) - y_mean)
    sq_err = np.zeros(len(alphas))
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(0, len(scored_x), _ROW_BLOCK):
            x = centred(scored_x, i)
            resid = scored_y[i:i + _ROW_BLOCK, :, None] - (x @ coefs).reshape(len(x), -1,
                                                                               len(alphas))
            if validation is None:
                z = x @ vecs
                resid /= 1.0 - ((z * z) @ inverse + 1.0 / n)[:, None, :]
            sq_err += (resid ** 2).sum(axis=(0, 1))
    mse = sq_err / scored_y.size
    best = int(np.argmin(np.where(np.isfinite(mse), mse, np.inf)))
    coef = coefs.reshape(p, -1, len(alphas))[:, :, best]
    return coef, y_mean - x_mean @ coef, best, mse


@dataclass
class _Fitted:
    """What predict needs: the fitted transforms, the scaling of the (n_hydra Hydra +
    MultiRocket) feature columns and the ridge weights."""

    n_channels: int
    multirocket: object
    hydra: object
    n_hydra: int
    offset: np.ndarray
    scale: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray
    alpha: float


def _positive_int(name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


class RocketRegressor:
    """MultiRocket-Hydra features + ridge regression, a window model:
    (B, L, F) standard-scaled windows -> (B, 3) standard-scaled targets of each last sample.

    Defaults for the paper's 100-sample windows give 5,056 features: MultiRocket 4,032
    (8 x 84 x floor(n_kernels_multirocket / 84): 4 pooling operators x series and difference)
    and Hydra 1,024 (4 dilations x 2 count types x n_kernels_hydra). ``n_kernels_hydra`` is
    Hydra's kernels per dilation, in groups of :data:`HYDRA_KERNELS_PER_GROUP`, half on the
    series and half on its difference. aeon's own defaults (6,250 and 512, ~54,000 features)
    cost ~10x as much per window and exceed :data:`MAX_FEATURES`.
    """

    kind = "window"  # not a torch module: fitted in closed form (psmforce.estimators.networks.contract)
    output_space = "scaled"

    def __init__(self, window: int = 100, n_kernels_multirocket: int = 504,
                 n_kernels_hydra: int = 128,
                 max_train_windows: int = DEFAULT_MAX_TRAIN_WINDOWS, seed: int = 0,
                 threads: int = 1):
        self.window = _positive_int("window", window, 9)  # both transforms use length-9 kernels
        self.n_kernels_multirocket = _positive_int("n_kernels_multirocket",
                                                   n_kernels_multirocket, 84)
        self.n_kernels_hydra = _positive_int("n_kernels_hydra", n_kernels_hydra,
                                             2 * HYDRA_KERNELS_PER_GROUP)
        if self.n_kernels_hydra % (2 * HYDRA_KERNELS_PER_GROUP):
            raise ValueError(f"n_kernels_hydra must be a multiple of "
                             f"{2 * HYDRA_KERNELS_PER_GROUP} (groups of "
                             f"{HYDRA_KERNELS_PER_GROUP}, half on the series, half on its "
                             f"difference), got {n_kernels_hydra}")
        self.max_train_windows = _positive_int("max_train_windows", max_train_windows, 2)
        self.seed = _positive_int("seed", seed, 0)
        self.threads = _positive_int("threads", threads)
        self._fitted: _Fitted | None = None

    def config(self) -> dict:
        """Constructor keyword arguments (JSON-serialisable)."""
        return {"window": self.window, "n_kernels_multirocket": self.n_kernels_multirocket,
                "n_kernels_hydra": self.n_kernels_hydra,
                "max_train_windows": self.max_train_windows, "seed": self.seed,
                "threads": self.threads}

    def _check_windows(self, windows, name: str = "windows") -> np.ndarray:
        windows = np.asarray(windows)
        if windows.ndim != 3:
            raise ValueError(f"{name} must be (N, L, F) = (N, {self.window}, features), got "
                             f"shape {windows.shape}")
        if windows.shape[1] != self.window:
            raise ValueError(f"{name} are {windows.shape[1]} samples long, the model's window "
                             f"is {self.window}")
        if windows.shape[2] < 1:
            raise ValueError(f"{name} have no feature columns")
        if self._fitted is not None and windows.shape[2] != self._fitted.n_channels:
            raise ValueError(f"{name} have {windows.shape[2]} features, the model was fitted "
                             f"on {self._fitted.n_channels}")
        return windows

    def _check_targets(self, targets, n: int, name: str = "targets") -> np.ndarray:
        targets = np.asarray(targets)
        if targets.shape != (n, 3):
            raise ValueError(f"{name} must be (N, 3) = ({n}, 3) for {n} windows, got shape "
                             f"{targets.shape}")
        finite = np.isfinite(targets).all(axis=1)
        if not finite.all():
            raise ValueError(f"{name} row {int(np.argmin(finite))} contains NaN or inf")
        return targets

    @staticmethod
    def _aeon_layout(windows: np.ndarray, index: np.ndarray, name: str) -> np.ndarray:
        """(b, L, F) -> contiguous (b, F, L) float32; NaN or inf names the first bad window by
        its ``index`` in the caller's array."""
        x = np.ascontiguousarray(np.asarray(windows, dtype=np.float32).transpose(0, 2, 1))
        finite = np.isfinite(x).all(axis=(1, 2))
        if not finite.all():
            raise ValueError(f"{name} window {int(index[np.argmin(finite)])} contains NaN or inf")
        return x

    def subsample_indices(self, n: int, stream: int) -> np.ndarray:
        """Sorted indices of at most ``max_train_windows`` of ``n`` windows, drawn with the seed
        (``stream`` keeps training and validation draws independent)."""
        if n <= self.max_train_windows:
            return np.arange(n)
        rng = np.random.default_rng([self.seed, stream])
        return np.sort(rng.choice(n, self.max_train_windows, replace=False))

    def _fit_transforms(self, x: np.ndarray) -> tuple:
        """aeon's MultiRocket and Hydra transforms of this config fitted on (n, F, L) windows
        (Hydra's kernels depend on the seed only; MultiRocket's biases on ``x``)."""
        from aeon.transformations.collection.convolution_based import (HydraTransformer,
                                                                       MultiRocket)
        multirocket = MultiRocket(n_kernels=self.n_kernels_multirocket, n_jobs=self.threads,
                                  random_state=self.seed).fit(x)
        hydra = HydraTransformer(n_kernels=HYDRA_KERNELS_PER_GROUP,
                                 n_groups=self.n_kernels_hydra // HYDRA_KERNELS_PER_GROUP,
                                 n_jobs=self.threads, random_state=self.seed,
                                 output_type="numpy").fit(x)
        return multirocket, hydra

    def _checked_pair(self, windows, targets, val_windows, val_targets):
        windows = self._check_windows(windows)
        if len(windows) < 2:
            raise ValueError(f"fit needs at least 2 windows, got {len(windows)}")
        targets = self._check_targets(targets, len(windows))
        if (val_windows is None) != (val_targets is None):
            raise ValueError("give both val_windows and val_targets, or neither")
        if val_windows is not None:
            val_windows = self._check_windows(val_windows, "val_windows")
            if len(val_windows) < 1:
                raise ValueError("val_windows is empty")
            val_targets = self._check_targets(val_targets, len(val_windows), "val_targets")
            if val_windows.shape[2] != windows.shape[2]:
                raise ValueError(f"val_windows have {val_windows.shape[2]} features, windows "
                                 f"{windows.shape[2]}")
        return windows, targets, val_windows, val_targets

    def _fit_ridge(self, features, targets, used, val_windows, val_targets,
                   transforms: tuple, head: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
        """Ridge on standardised ``features`` (the ``used`` training windows), its penalty chosen
        on the validation windows' features when given; sets ``self._fitted``. ``head`` = (coef,
        intercept) of a fitted ridge: the penalty then pulls towards it, not towards zero (the
        ridge learns the residual of that head), so a large penalty keeps it."""
        n_channels, multirocket, hydra, n_hydra, offset, scale = transforms
        targets = np.asarray(targets[used], dtype=np.float64)
        validation = None
        if val_windows is not None:
            val_used = self.subsample_indices(len(val_windows), 1)
            val_features = _feature_matrix(multirocket, hydra, self._aeon_layout(
                val_windows[val_used], val_used, "validation"))
            _standardise(val_features, offset, scale, n_hydra)
            validation = (val_features, np.asarray(val_targets[val_used], dtype=np.float64))
        if head is not None:  # head[0] float32 like the features: no float64 copy of them
            targets = targets - (features @ head[0] + head[1])
            if validation is not None:
                validation = (validation[0],
                              validation[1] - (validation[0] @ head[0] + head[1]))
        coef, intercept, best, mse = _ridge(features, targets, ALPHAS, validation)
        if head is not None:
            coef, intercept = coef + head[0], intercept + head[1]
        self._fitted = _Fitted(n_channels, multirocket, hydra, n_hydra, offset, scale,
                               coef.astype(np.float32), intercept, float(ALPHAS[best]))
        return {"n_windows_used": len(used), "n_features": features.shape[1],
                "alpha": float(ALPHAS[best]),
                "criterion": "leave-one-out" if validation is None else "validation",
                "criterion_rmse": float(np.sqrt(mse[best]))}

    def fit(self, windows: np.ndarray, targets: np.ndarray, val_windows: np.ndarray | None = None,
            val_targets: np.ndarray | None = None) -> dict:
        """Fit on standard-scaled windows (N, L, F) and their scaled targets (N, 3); zero-copy
        views are fine, only the subsampled windows are gathered. ``val_windows``/``val_targets``
        (other trials, scaled alike, also capped at ``max_train_windows``) choose the penalty;
        without them leave-one-out does (see the module docstring). Returns a report: windows
        used, features, chosen alpha, the criterion and its RMSE at that alpha (scaled units,
        over the three axes), seconds."""
        start = time.perf_counter()
        self._fitted = None
        windows, targets, val_windows, val_targets = self._checked_pair(
            windows, targets, val_windows, val_targets)
        used = self.subsample_indices(len(windows), 0)
        with _threads(self.threads), _own_global_rngs():
            x = self._aeon_layout(windows[used], used, "training")
            multirocket, hydra = self._fit_transforms(x)
            n_hydra = hydra.transform(x[:1]).shape[1]
            features = _feature_matrix(multirocket, hydra, x)
            del x
            offset, scale = _scaling(features, n_hydra)
            _standardise(features, offset, scale, n_hydra)
            report = self._fit_ridge(features, targets, used, val_windows, val_targets,
                                     (windows.shape[2], multirocket, hydra, n_hydra, offset,
                                      scale))
        return report | {"seconds": round(time.perf_counter() - start, 2)}

    def refit_head(self, windows: np.ndarray, targets: np.ndarray,
                   val_windows: np.ndarray | None = None,
                   val_targets: np.ndarray | None = None) -> dict:
        """Finetuning's analogue: the fitted transforms and feature scaling stay (the frozen
        trunk), the ridge (the head) is fitted again on new windows, its penalty, chosen on
        ``val_windows`` when given, pulling towards the fitted head rather than towards zero.
        Why: finetuning starts from the pretrained weights and stops early, so a few minutes of
        new trials move a network's head only as far as they justify; a ridge refitted from
        zero on them forgets every condition they lack (on a new tool's free-space and traction
        trials, the palpation it was trained on). Same arguments and report as :meth:`fit`."""
        if self._fitted is None:
            raise RuntimeError("RocketRegressor.refit_head called before fit (or "
                               "load_state_dict)")
        start = time.perf_counter()
        windows, targets, val_windows, val_targets = self._checked_pair(
            windows, targets, val_windows, val_targets)
        f = self._fitted
        used = self.subsample_indices(len(windows), 0)
        with _threads(self.threads):
            features = _feature_matrix(f.multirocket, f.hydra,
                                       self._aeon_layout(windows[used], used, "training"))
            _standardise(features, f.offset, f.scale, f.n_hydra)
            report = self._fit_ridge(features, targets, used, val_windows, val_targets,
                                     (f.n_channels, f.multirocket, f.hydra, f.n_hydra,
                                      f.offset, f.scale),
                                     head=(f.coef, f.intercept))
        return report | {"seconds": round(time.perf_counter() - start, 2)}

    def predict(self, windows: np.ndarray, batch: int = 4096) -> np.ndarray:
        """(N, 3) float32 scaled estimates for (N, L, F) standard-scaled windows, ``batch``
        windows at a time (features: batch x 5,056 float32, 83 MB at the defaults); ~650
        windows/s on one thread."""
        if self._fitted is None:
            raise RuntimeError("RocketRegressor.predict called before fit (or load_state_dict)")
        windows = self._check_windows(windows)
        batch = _positive_int("batch", batch)
        fitted = self._fitted
        out = np.empty((len(windows), 3), dtype=np.float32)
        with _threads(self.threads):
            for i in range(0, len(windows), batch):
                x = self._aeon_layout(windows[i:i + batch], np.arange(i, i + batch), "input")
                block = _raw_features(fitted.multirocket, fitted.hydra, x)
                _standardise(block, fitted.offset, fitted.scale, fitted.n_hydra)
                out[i:i + batch] = block @ fitted.coef + fitted.intercept
        return out

    def _state_keys(self) -> list[str]:
        aeon_arrays = [f"multirocket.{name}.{i}" for name in ("parameter", "parameter1")
                       for i in range(_MULTIROCKET_ARRAYS)]
        return aeon_arrays + ["hydra.W", "hydra.idx", "offset", "scale", "coef", "intercept",
                              "alpha", "n_hydra", "n_channels"]

    def state_dict(self) -> dict[str, torch.Tensor]:
        """The fitted model as plain tensors (what a checkpoint stores): MultiRocket's fitted
        arrays, Hydra's kernels and channel choices, the scaling, the ridge."""
        if self._fitted is None:
            raise RuntimeError("RocketRegressor.state_dict called before fit")
        f = self._fitted
        state = {f"multirocket.{name}.{i}": torch.from_numpy(np.array(a))
                 for name in ("parameter", "parameter1")
                 for i, a in enumerate(getattr(f.multirocket, name))}
        state |= {"hydra.W": f.hydra._hydra.W.detach().clone(),
                  "hydra.idx": torch.stack(list(f.hydra._hydra.idx)),
                  "offset": torch.from_numpy(f.offset), "scale": torch.from_numpy(f.scale),
                  "coef": torch.from_numpy(f.coef),
                  "intercept": torch.from_numpy(np.asarray(f.intercept, dtype=np.float64)),
                  "alpha": torch.tensor(f.alpha, dtype=torch.float64),
                  "n_hydra": torch.tensor(f.n_hydra), "n_channels": torch.tensor(f.n_channels)}
        return state

    def load_state_dict(self, state: dict, strict: bool = True) -> None:
        """Inverse of :meth:`state_dict`: aeon's transforms are built on a dummy input of the
        saved shape (which sets their bookkeeping), then given the saved arrays. Raises
        RuntimeError naming what does not fit (missing or unexpected keys, shapes)."""
        keys = self._state_keys()
        missing, extra = sorted(set(keys) - set(state)), sorted(set(state) - set(keys))
        if missing or (strict and extra):
            raise RuntimeError(f"RocketRegressor state: missing keys {missing}, unexpected "
                               f"keys {extra}")
        n_channels, n_hydra = int(state["n_channels"]), int(state["n_hydra"])
        if n_channels < 1 or n_hydra < 1:
            raise RuntimeError(f"RocketRegressor state: n_channels {n_channels}, n_hydra "
                               f"{n_hydra} must be positive")
        dummy = np.zeros((2, n_channels, self.window), dtype=np.float32)
        with _threads(self.threads), _own_global_rngs():
            multirocket, hydra = self._fit_transforms(dummy)
        for name in ("parameter", "parameter1"):
            built = getattr(multirocket, name)
            saved = tuple(state[f"multirocket.{name}.{i}"].numpy().astype(a.dtype, copy=False)
                          for i, a in enumerate(built))
            # Array lengths depend on the fitted channel choices; the kernel count does not.
            if saved[0].shape != built[0].shape or saved[4].shape != built[4].shape:
                raise RuntimeError(f"RocketRegressor state: MultiRocket {name} has "
                                   f"{saved[0].shape[0]} kernels, the config gives "
                                   f"{built[0].shape[0]}")
            setattr(multirocket, name, saved)
        for key, built in (("hydra.W", hydra._hydra.W),
                           ("hydra.idx", torch.stack(list(hydra._hydra.idx)))):
            if state[key].shape != built.shape:
                raise RuntimeError(f"RocketRegressor state: {key} has shape "
                                   f"{tuple(state[key].shape)}, the config gives "
                                   f"{tuple(built.shape)}")
        hydra._hydra.W = state["hydra.W"].to(hydra._hydra.W.dtype).clone()
        hydra._hydra.idx = list(state["hydra.idx"].to(hydra._hydra.idx[0].dtype).unbind())
        p = _raw_features(multirocket, hydra, dummy[:1]).shape[1]
        shapes = {"offset": (p,), "scale": (p,), "coef": (p, 3), "intercept": (3,)}
        for key, shape in shapes.items():
            if tuple(state[key].shape) != shape:
                raise RuntimeError(f"RocketRegressor state: {key} has shape "
                                   f"{tuple(state[key].shape)}, the transforms give {shape}")
        self._fitted = _Fitted(n_channels, multirocket, hydra, n_hydra,
                               state["offset"].numpy().astype(np.float32),
                               state["scale"].numpy().astype(np.float32),
                               state["coef"].numpy().astype(np.float32),
                               state["intercept"].numpy().astype(np.float64),
                               float(state["alpha"]))

    def n_parameters(self) -> int:
        """Fitted ridge weights and intercepts (the random kernels are not learned)."""
        if self._fitted is None:
            raise RuntimeError("RocketRegressor.n_parameters called before fit")
        return int(self._fitted.coef.size + self._fitted.intercept.size)

    def to(self, device) -> "RocketRegressor":
        """Checkpoint-loading symmetry with torch models: features run on the CPU in numpy."""
        return self

    def eval(self) -> "RocketRegressor":
        return self
