"""MultiRocket-Hydra baseline (psmforce.estimators.networks.rocket): learning, determinism, saving, refitting,
input errors; train / evaluate / finetune through checkpoints.

Small windows (40 samples, 4 channels) and kernel counts keep each fit to about a second once
numba has compiled aeon's kernels (the first fit in a fresh environment compiles them, ~40 s).
"""

import numpy as np
import pytest

pytest.importorskip("aeon")

from scipy.signal import lfilter  # noqa: E402

from psmforce.estimators.networks.rocket import ALPHAS, RocketRegressor, _ridge  # noqa: E402

WINDOW, CHANNELS = 40, 4
SMALL = dict(window=WINDOW, n_kernels_multirocket=168, n_kernels_hydra=32)


def _data(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Independent AR(1) windows (n, 40, 4) and three known functions of each: the last sample
    of channel 0 plus a lagged mean of channel 1, the window mean of channel 2, the roughness
    (mean absolute difference) of channel 3."""
    rng = np.random.default_rng(seed)
    w = lfilter([0.3], [1, -0.7], rng.standard_normal((n, WINDOW + 50, CHANNELS)), axis=1)
    w = (w[:, 50:] / 0.42).astype(np.float32)
    y = np.stack([w[:, -1, 0] + w[:, -20:-10, 1].mean(axis=1),
                  w[:, :, 2].mean(axis=1),
                  np.abs(np.diff(w[:, :, 3], axis=1)).mean(axis=1)], axis=1)
    return w, y.astype(np.float32)


def _r2(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return 1 - ((pred - truth) ** 2).sum(0) / ((truth - truth.mean(0)) ** 2).sum(0)


@pytest.fixture(scope="module")
def data():
    return _data(1600)


@pytest.fixture(scope="module")
def fitted(data):
    w, y = data
    model = RocketRegressor(**SMALL)
    report = model.fit(w[:1000], y[:1000], w[1000:1250], y[1000:1250])
    return model, report


def test_learns_a_known_function_of_the_window(data, fitted):
    w, y = data
    model, report = fitted
    assert report["n_windows_used"] == 1000 and report["criterion"] == "validation"
    assert report["n_features"] > 0 and report["alpha"] in ALPHAS
    r2 = _r2(model.predict(w[1250:]), y[1250:])
    assert (r2 > 0.5).all(), r2  # the mean predictor scores 0; a broken fit scores <= 0


@pytest.mark.slow
def test_deterministic_given_seed_and_leaves_global_state(data):
    import torch
    w, y = data
    preds = []
    for seed in (0, 0, 1):
        np_state, torch_state = np.random.get_state()[1].copy(), torch.get_rng_state()
        threads = torch.get_num_threads()
        model = RocketRegressor(**SMALL, max_train_windows=600, seed=seed)
        report = model.fit(w[:800], y[:800])
        # aeon seeds numpy's and torch's global generators and sets torch's thread count
        np.testing.assert_array_equal(np.random.get_state()[1], np_state)
        assert torch.equal(torch.get_rng_state(), torch_state)
        assert torch.get_num_threads() == threads
        assert report["n_windows_used"] == 600 and report["criterion"] == "leave-one-out"
        preds.append(model.predict(w[1250:1350]))
    np.testing.assert_array_equal(preds[0], preds[1])
    assert not np.array_equal(preds[0], preds[2])


def test_numba_runs_on_its_workqueue_not_a_second_openmp(fitted):
    # numba's OpenMP pool beside torch's left torch's attention about 85x slower in the process
    import numba
    if numba.config.THREADING_LAYER not in ("default", "workqueue"):
        pytest.skip(f"the user chose numba's {numba.config.THREADING_LAYER} layer")
    assert numba.threading_layer() == "workqueue"


def test_round_trip_through_plain_tensors(data, fitted):
    import torch
    w, _ = data
    model, _ = fitted
    state = model.state_dict()
    assert all(isinstance(v, torch.Tensor) for v in state.values())  # no pickled objects
    loaded = RocketRegressor(**model.config())
    loaded.load_state_dict(state)
    np.testing.assert_array_equal(loaded.predict(w[1250:1300]), model.predict(w[1250:1300]))
    # batching changes only float32 rounding (BLAS blocks by shape)
    np.testing.assert_allclose(model.predict(w[1250:1300], batch=7),
                               model.predict(w[1250:1300]), rtol=1e-5, atol=1e-5)
    with pytest.raises(RuntimeError, match="missing keys.*coef"):
        RocketRegressor(**model.config()).load_state_dict(
            {k: v for k, v in state.items() if k != "coef"})
    with pytest.raises(RuntimeError, match="kernels, the config gives"):
        RocketRegressor(**{**model.config(), "n_kernels_multirocket": 252}).load_state_dict(state)


@pytest.mark.slow
def test_refit_head_keeps_the_transforms_and_learns_the_new_targets(data, fitted):
    w, y = data
    model, _ = fitted
    copy = RocketRegressor(**model.config())
    copy.load_state_dict(model.state_dict())
    flipped = -2.0 * y + 1.0  # a new tool: same features, other mapping
    report = copy.refit_head(w[:1000], flipped[:1000], w[1000:1250], flipped[1000:1250])
    assert report["criterion"] == "validation"
    np.testing.assert_array_equal(copy._fitted.scale, model._fitted.scale)
    assert (_r2(copy.predict(w[1250:]), flipped[1250:]) > 0.5).all()
    assert (_r2(model.predict(w[1250:]), flipped[1250:]) < 0).all()  # the old head is wrong


def test_refit_head_pulls_towards_the_fitted_head(data, fitted):
    """A few windows whose targets the fitted head already predicts leave it where it is (the
    penalty pulls towards it, not towards zero: a ridge refitted from zero on 60 windows would
    not reproduce the head fitted on 1,000)."""
    w, _ = data
    model, _ = fitted
    copy = RocketRegressor(**model.config())
    copy.load_state_dict(model.state_dict())
    own = model.predict(w[:60])
    copy.refit_head(w[:40], own[:40], w[40:60], own[40:60])
    held_out = model.predict(w[1250:])
    np.testing.assert_allclose(copy.predict(w[1250:]), held_out,
                               atol=1e-4 * np.abs(held_out).max())


def test_bad_inputs_raise_naming_the_problem(data, fitted):
    w, y = data
    model, _ = fitted
    fresh = RocketRegressor(**SMALL)
    with pytest.raises(RuntimeError, match="before fit"):
        fresh.predict(w[:5])
    with pytest.raises(ValueError, match=r"\(N, L, F\)"):
        fresh.fit(w[:, :, 0], y)
    with pytest.raises(ValueError, match="30 samples long"):
        fresh.fit(w[:, :30], y)
    with pytest.raises(ValueError, match=r"targets must be \(N, 3\)"):
        fresh.fit(w[:100], y[:99])
    bad = w[:100].copy()
    bad[7, 3, 1] = np.nan
    with pytest.raises(ValueError, match="window 7 contains NaN"):
        fresh.fit(bad, y[:100])
    bad_y = y[:100].copy()
    bad_y[5, 2] = np.inf
    with pytest.raises(ValueError, match="targets row 5"):
        fresh.fit(w[:100], bad_y)
    with pytest.raises(ValueError, match="both val_windows and val_targets"):
        fresh.fit(w[:100], y[:100], val_windows=w[100:120])
    with pytest.raises(ValueError, match="window 3 contains NaN"):
        model.predict(bad[4:10])
    with pytest.raises(ValueError, match="fitted on 4"):
        model.predict(w[:5, :, :3])
    with pytest.raises(ValueError, match="multiple of 16"):
        RocketRegressor(n_kernels_hydra=20)
    with pytest.raises(ValueError, match="window must be"):
        RocketRegressor(window=5)


@pytest.mark.parametrize("n, p", [(300, 30), (40, 90)])
def test_ridge_matches_sklearn(n, p):
    """The closed-form ridge picks the alpha and weights sklearn's RidgeCV (leave-one-out)
    picks, and its validation errors are those of sklearn's Ridge."""
    from sklearn.linear_model import Ridge, RidgeCV
    rng = np.random.default_rng(n)
    x = (rng.standard_normal((n, p)) * rng.uniform(0.1, 3, p) + 2).astype(np.float32)
    y = x[:, :5] @ rng.standard_normal((5, 3)) + rng.standard_normal((n, 3))
    coef, intercept, best, _ = _ridge(x, y)
    ref = RidgeCV(alphas=ALPHAS).fit(x.astype(np.float64), y)
    assert ALPHAS[best] == ref.alpha_
    np.testing.assert_allclose(coef.T, ref.coef_, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(intercept, ref.intercept_, rtol=1e-7, atol=1e-9)
    xv, yv = x[:20] + 0.5, y[:20]
    _, _, _, mse = _ridge(x, y, ALPHAS, (xv, yv))
    expected = [((Ridge(alpha=a).fit(x.astype(np.float64), y).predict(xv) - yv) ** 2).mean()
                for a in ALPHAS]
    np.testing.assert_allclose(mse, expected, rtol=1e-7)
