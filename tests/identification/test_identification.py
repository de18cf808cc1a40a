"""Arm dynamics identification: inertia parametrisation, bad input, and the WPI real-data fit."""
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from psmforce.robot.conventions import JOINTS
from psmforce.identification import (ArmDynamicsModel, fit_arm_dynamics, fit_dynamics_cli,
                                      external_wrench_on_tool)
from psmforce.identification import dynamics_regressor as reg
from psmforce.identification import inertia as inr
from psmforce.identification import signals, wpi, wpi_report
from psmforce.identification.dynamics_fit import condition_signals
from psmforce.identification.dynamics_options import (HYSTERESIS_BREAKAWAY_M,
                                                       HYSTERESIS_BREAKAWAY_RAD, INSERTION,
                                                       SELECTION_CANDIDATES, DynamicsFitOptions)
from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.wpi_report import PUBLISHED_WANG_2019_PERCENT

WPI_DIR = Path(os.environ.get("PSM_WPI_DATA",
                              Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "wpi_psm"))
needs_wpi = pytest.mark.skipif(not (WPI_DIR / "one_results.csv").is_file(),
                               reason="WPI recordings not available")


def test_log_cholesky_round_trip_and_consistency():
    rng = np.random.default_rng(0)
    for _ in range(20):
        theta = rng.normal(size=10)
        pi = inr.theta_to_parameters(theta)
        rep = inr.consistency_report(pi)
        assert rep["physically_consistent"] and pi[0] > 0
        assert np.allclose(inr.parameters_to_theta(pi), theta, atol=1e-8)
    # a point mass of 2 kg at (0.1, 0, 0): I_yy = I_zz = 0.02 about the origin
    pi = inr.parameters_from_pseudo_inertia(inr.pseudo_inertia([2, 0.2, 0, 0, 0, 0, 0.02, 0, 0, 0.02]))
    assert np.allclose(pi, [2, 0.2, 0, 0, 0, 0, 0.02, 0, 0, 0.02])


def test_signal_conditioning_zero_phase_and_derivative():
    t = np.arange(0, 10, 1 / 200)
    x = np.sin(2 * np.pi * 0.5 * t)
    y = signals.zero_phase_lowpass(x, 200, 5.4)
    assert np.max(np.abs(y - x)[200:-200]) < 1e-3  # no lag, no attenuation in the pass band
    dx = signals.derivative(y, 200)
    assert np.max(np.abs(dx - np.pi * np.cos(np.pi * t))[200:-200]) < 5e-3
    with pytest.raises(IdentificationInputError, match="Nyquist"):
        signals.zero_phase_lowpass(x, 200, 150)


def _synthetic(n=2000):
    t = np.arange(n) / 200
    c = np.stack([0.3 * np.sin(0.7 * t * (k + 1)) for k in range(7)], axis=1)
    c[:, 2] = 0.1 + 0.05 * np.sin(t)
    dc = np.gradient(c, 1 / 200, axis=0)
    return c, dc, 0.1 * dc


def test_bad_input_errors():
    c, dc, tau = _synthetic()
    bad = c.copy()
    bad[10, 3] = np.nan
    with pytest.raises(IdentificationInputError, match="non-finite.*row 10"):
        fit_arm_dynamics(bad, dc, tau, sample_rate_hz=200)
    with pytest.raises(IdentificationInputError, match="too short"):
        fit_arm_dynamics(c[:500], dc[:500], tau[:500], sample_rate_hz=200)
    with pytest.raises(IdentificationInputError, match="same shape|7 columns"):
        fit_arm_dynamics(c, dc[:, :6], tau, sample_rate_hz=200)
    with pytest.raises(IdentificationInputError, match="same shape"):
        fit_arm_dynamics(c, dc[:-1], tau, sample_rate_hz=200)
    still = dc.copy()
    still[:, 4] = 0.0
    with pytest.raises(IdentificationInputError, match="does not excite wrist_pitch"):
        fit_arm_dynamics(c, still, tau, sample_rate_hz=200)


def test_wpi_loader_conversion(tmp_path):
    rows = np.arange(21 * 3, dtype=float).reshape(3, 21) / 100
    f = tmp_path / "x.csv"
    np.savetxt(f, rows, delimiter=",")
    rec = wpi.load_wpi(f)
    q, dq, tau = rec.to_dvrk()
    assert np.allclose(q[:, 4:], rows[:, 4:7] @ wpi.WRIST_MOTOR_TO_DVRK.T)
    # virtual work is preserved: tau_dvrk . dq_dvrk == tau_motor . dq_motor
    assert np.allclose((tau * dq).sum(1), (rec.tau * rec.dq).sum(1))
    np.savetxt(f, rows[:, :20], delimiter=",")
    with pytest.raises(IdentificationInputError, match="21 columns"):
        wpi.load_wpi(f)


@pytest.fixture(scope="module")
def wpi_fit(tmp_path_factory):
    """One fit on the WPI training file, shared by the tests (about 10 s)."""
    d = tmp_path_factory.mktemp("wpi")
    out, model_path = d / "report.json", d / "model.json"
    rep = fit_dynamics_cli(WPI_DIR / "one_results.csv", WPI_DIR / "two_results.csv", "wpi",
                           out, model_path)
    return rep, out, model_path


@pytest.mark.slow
@needs_wpi
def test_wpi_fit_published_protocol(wpi_fit, tmp_path):
    rep, out, model_path = wpi_fit
    assert json.loads(out.read_text())["test_relative_error_percent"] == rep["test_relative_error_percent"]
    assert rep["converged"] and rep["physically_consistent"]
    assert rep["published_wang_2019_percent"] == list(PUBLISHED_WANG_2019_PERCENT)
    assert 0 < rep["n_base_parameters"] <= rep["n_parameters"]
    assert abs(np.linalg.norm(rep["gravity_mps2"]) - 9.81) < 1e-6
    cw = rep["insertion_counterweight"]  # the default's weightless mass: a point mass
    assert cw["mass_kg"] >= 0
    assert cw["second_moment_kg_m2"] >= cw["mass_kg"] * cw["position_m"] ** 2 - 1e-6
    errs = np.array(rep["test_relative_error_percent"])
    assert (errs < 40).all()  # a sane model on an independent trajectory (not the published target)
    model = ArmDynamicsModel.load(model_path)
    rec = wpi.load_wpi(WPI_DIR / "two_results.csv")
    q, dq, tau = rec.to_dvrk()
    ddq = signals.derivative(dq, 200)
    a = model.predict(q[:300], dq[:300], ddq[:300])
    c = model.predict_coordinates(rec.q[:300], rec.dq[:300], signals.derivative(rec.dq, 200)[:300])
    assert np.allclose(a @ wpi.coordinates_to_dvrk_matrix(), c)  # tau_c = T^T tau_q
    model.converged = False
    with pytest.raises(NotConvergedError):
        model.save(tmp_path / "never.json")
    assert not (tmp_path / "never.json").exists()
    # a file from before the counterweight option: no such key, no such parameters (and, older
    # than the integrity envelope, neither its digest nor its format version)
    d = json.loads(model_path.read_text())
    assert d.pop("format_version") == 2 and "all" in d.pop("sha256")
    del d["options"]["insertion_counterweight"]
    d["linear_parameters"] = {k: v for k, v in d["linear_parameters"].items()
                              if not k.startswith("insertion_counterweight.")}
    (tmp_path / "old.json").write_text(json.dumps(d))
    old = ArmDynamicsModel.load(tmp_path / "old.json")
    assert not old.options.insertion_counterweight
    assert old.predict(q[:5], dq[:5], ddq[:5]).shape == (5, 7)


@pytest.mark.slow
@needs_wpi
def test_external_wrench_recovers_applied_wrench(wpi_fit):
    from psmforce.robot import PSM

    model = ArmDynamicsModel.load(wpi_fit[2])
    rng = np.random.default_rng(3)
    n = 5
    q = np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(0.08, 0.2, n),
                         rng.uniform(-1, 1, (n, 3)), rng.uniform(0, 0.5, n)])
    dq, ddq = rng.normal(size=(n, 7)) * 0.1, rng.normal(size=(n, 7)) * 0.1
    w_true = np.column_stack([rng.normal(size=(n, 3)), 0.01 * rng.normal(size=(n, 3))])
    J = PSM().spatial_jacobian(q)  # (n,6,6), rows [v; w], WORLD: dual of expressed_in="base"
    tau = model.predict(q, dq, ddq)
    tau[:, :6] -= np.einsum("nij,ni->nj", J, w_true)  # motors balance the load: -J^T w
    w = external_wrench_on_tool(model, q, dq, ddq, tau)
    assert np.allclose(w, w_true, atol=1e-6)


def test_regressor_matches_rnea_of_constrained_model():
    """Y(q, dq, ddq; g) pi equals G^T rnea of the 8-joint model (coupler at -q2) for the prior pi."""
    import pinocchio as pin

    model, _ = reg.identification_model()
    data = model.createData()
    rng = np.random.default_rng(0)
    q6, v6, a6 = rng.normal(size=(3, 4, 6))
    Y0, Yg, mass_cols = reg.rigid_regressors(model, q6, v6, a6)
    pi = np.concatenate([model.inertias[model.getJointId(b)].toDynamicParameters()
                         for b in reg.BODIES])
    g = np.array([0.0, 0.0, -9.81])
    tau = Y0 @ pi + np.einsum("k,knjp,p->nj", g, Yg, pi[mass_cols])
    model.gravity = pin.Motion(g, np.zeros(3))
    for i in range(4):
        ext = [reg.extended_joints(x[i:i + 1])[0] for x in (q6, v6, a6)]
        assert np.allclose(reg.CONSTRAINT_JACOBIAN.T @ pin.rnea(model, data, *ext), tau[i],
                           atol=1e-10)
    # the coupler does not rotate: its absolute orientation is the yaw body's for any pitch
    pin.forwardKinematics(model, data, reg.extended_joints(q6[:1])[0])
    R_yaw = data.oMi[model.getJointId("yaw")].rotation
    R_coupler = data.oMi[model.getJointId("parallelogram_coupler")].rotation
    R_pitch_rest = model.jointPlacements[model.getJointId("parallelogram_crank")].rotation
    assert np.allclose(R_coupler, R_yaw @ R_pitch_rest, atol=1e-12)


def test_counterweight_columns_are_a_weightless_point_mass_on_the_insertion_axis():
    """The counterweight's columns times (m, m z, m z^2) are the torques of a point mass m at z
    on the insertion axis without its weight: G^T rnea of the identification model holding only
    that mass, gravity off; and in closed form, from rest, m * ddq3 on the insertion and
    m |p|^2 * ddq2 on the pitch (the insertion axis crosses the pitch axis at the RCM, p the
    point's position from the RCM). Its weight is absent: no torque at rest with gravity on."""
    import pinocchio as pin

    m, z = 0.4, -0.1
    model, _ = reg.identification_model()
    for jid in range(1, model.njoints):  # only the point mass on the insertion body
        model.inertias[jid] = pin.Inertia.Zero()
    ins = model.getJointId("insertion")
    model.inertias[ins] = pin.Inertia(m, np.array([0.0, 0.0, z]), np.zeros((3, 3)))
    model.gravity = pin.Motion.Zero()
    data = model.createData()
    rng = np.random.default_rng(1)
    q6, v6, a6 = rng.normal(size=(3, 5, 6))
    q6[:, 2] = rng.uniform(0.05, 0.2, 5)
    y0 = lambda *x: reg.rigid_regressors(reg.identification_model()[0], *x)[0]
    tau = reg.counterweight_columns(y0(q6, v6, a6)) @ np.array([m, m * z, m * z * z])
    for i in range(5):
        ext = [reg.extended_joints(x[i:i + 1])[0] for x in (q6, v6, a6)]
        np.testing.assert_allclose(reg.CONSTRAINT_JACOBIAN.T @ pin.rnea(model, data, *ext),
                                   tau[i], atol=1e-10)
    # closed form from rest: accelerate insertion only, then pitch only
    q = q6[:1]
    still = np.zeros((1, 6))
    a_ins, a_pitch = still.copy(), still.copy()
    a_ins[0, 2], a_pitch[0, 1] = 2.0, 3.0
    cols = lambda a: reg.counterweight_columns(y0(q, still, a))[0] @ np.array([m, m * z, m * z * z])
    assert np.isclose(cols(a_ins)[2], m * 2.0)
    pin.forwardKinematics(model, data, reg.extended_joints(q)[0])
    p = data.oMi[ins].act(np.array([0.0, 0.0, z]))
    assert np.isclose(cols(a_pitch)[1], m * (p @ p) * 3.0)
    assert np.allclose(cols(still), 0.0)  # at rest: no weight, whatever the pose


def test_excitation_period_and_phase_cross_validation_input():
    from psmforce.identification.dynamics_validation import phase_cross_validation

    t = np.arange(2400) / 200
    c = np.stack([0.3 * np.sin(2 * np.pi * 0.5 * t * (k + 1) + k) for k in range(7)], axis=1)
    assert signals.excitation_period(c, min_lag=200) == 400  # 2 s at 200 Hz
    assert signals.excitation_period(np.cumsum(np.ones((600, 2)), axis=0), min_lag=100) is None
    drifting = c + t[:, None]  # never repeats: phase folds are undefined, say so before fitting
    with pytest.raises(IdentificationInputError, match="no excitation period"):
        phase_cross_validation(drifting, np.ones_like(c), np.ones_like(c), sample_rate_hz=200,
                               options=DynamicsFitOptions(min_samples=500))


def test_hysteresis_columns_states_and_row_subsets():
    """The Maxwell-slip columns are the element states of their coordinate (grid per joint type)
    on its row only; states integrated on the whole sequence give the same columns for any subset
    of rows, which is how the cross-validation fits on phases of one recording."""
    from psmforce.identification import friction as fr

    c, dc, _ = _synthetic(600)
    ddc = np.gradient(dc, 1 / 200, axis=0)
    opts = DynamicsFitOptions(hysteresis_coordinates=(2, 3))
    T = wpi.coordinates_to_dvrk_matrix()
    L = reg.linear_columns(opts, T, c, dc, ddc)
    names = [t.name for t in reg.linear_terms(opts, wpi.MOTOR_COORDINATES)]
    for k, grid in ((2, HYSTERESIS_BREAKAWAY_M), (3, HYSTERESIS_BREAKAWAY_RAD)):
        idx = [i for i, n in enumerate(names)
               if n.startswith(f"{wpi.MOTOR_COORDINATES[k]}.friction.maxwell_slip_")]
        assert len(idx) == len(grid)
        block = L[:, :, idx]
        assert np.allclose(block[:, k], fr.maxwell_slip_states(c[:, k], grid))
        assert np.allclose(np.delete(block, k, axis=1), 0.0)  # acts on its own coordinate only
    z = reg.hysteresis_states(c)
    rows = np.arange(0, 600, 7)
    assert np.allclose(reg.linear_columns(opts, T, c[rows], dc[rows], ddc[rows], z[rows]),
                       L[rows])
    # conditioned states are integrated along the whole filtered recording, trimmed after
    o = DynamicsFitOptions(trim=50)
    raw = _synthetic(1200)
    out = condition_signals(*raw, 200.0, o, with_states=True)
    filt = signals.zero_phase_lowpass(raw[0], 200.0, o.cutoff_hz, order=o.filter_order)
    assert np.allclose(out[4], reg.hysteresis_states(filt)[50:-50])
    with pytest.raises(IdentificationInputError, match="hysteresis states"):
        reg.linear_columns(opts, T, c, dc, ddc, z[:10])


_EVERY_TERM = DynamicsFitOptions(stribeck=True, cross_springs=((0, 1), (2, 3)),
                                 spring_polynomial=((3, 3), (0, 2)), insertion_counterweight=True)


@pytest.mark.parametrize("opts", [*SELECTION_CANDIDATES.values(), _EVERY_TERM],
                         ids=[*SELECTION_CANDIDATES, "every term"])
def test_linear_term_names_match_their_columns(opts):
    """The parameters' names and the regressor's columns come from one term list: for every model
    variant they agree in count and order, each column being what its name says."""
    from psmforce.identification import friction as fr

    c, dc, _ = _synthetic(300)
    ddc = np.gradient(dc, 1 / 200, axis=0)
    T = wpi.coordinates_to_dvrk_matrix()
    coords = wpi.MOTOR_COORDINATES
    names = [t.name for t in reg.linear_terms(opts, coords)]
    L = reg.linear_columns(opts, T, c, dc, ddc)
    assert L.shape == (len(c), 7, len(names)) and len(set(names)) == len(names)
    dq = dc @ T.T
    for column, name in zip(np.moveaxis(L, 2, 0), names):
        owner, kind = name.split(".", 1)
        if owner.startswith("joint_"):  # friction on a dVRK wrist joint, in c through T^T
            j = JOINTS.index(owner.removeprefix("joint_"))
            f = (np.tanh(dq[:, j] / opts.friction_shape.smooth_sign_velocity)
                 if kind == "friction.coulomb" else dq[:, j])
            np.testing.assert_array_equal(column, np.outer(f, T[j]))
            continue
        if owner == "insertion_counterweight":  # chain-joint torques, in c through T^T
            q6, v6, a6 = ((x @ T.T)[:, :6] for x in (c, dc, ddc))
            p = [n for n, _, _ in reg.COUNTERWEIGHT_PARAMETERS].index(kind)
            np.testing.assert_allclose(column, np.einsum(
                "nj,jk->nk", reg.counterweight_columns(reg.rigid_regressors(
                    reg.identification_model()[0], q6, v6, a6)[0])[:, :, p], T[:6]), atol=1e-12)
            continue
        k = coords.index(owner)
        np.testing.assert_array_equal(np.delete(column, k, axis=1), 0.0)  # on its own row only
        shape = opts.friction_shape_prismatic if k == INSERTION else opts.friction_shape
        friction = fr.friction_regressor(dc[:, k], shape)
        slip = re.fullmatch(r"friction\.maxwell_slip_([0-9.]+)(m|rad)", kind)
        if kind == "armature":
            expected = ddc[:, k]
        elif kind == "spring":
            expected = c[:, k]
        elif kind.startswith("spring_from_"):
            expected = c[:, coords.index(kind.removeprefix("spring_from_"))]
        elif kind.startswith("spring_power_"):
            expected = c[:, k] ** int(kind.removeprefix("spring_power_"))
        elif kind == "friction.coulomb_asymmetry":
            expected = np.abs(friction[:, fr.TERMS.index("coulomb")])
        elif slip:
            grid = HYSTERESIS_BREAKAWAY_M if k == INSERTION else HYSTERESIS_BREAKAWAY_RAD
            assert slip[2] == ("m" if k == INSERTION else "rad")
            expected = fr.maxwell_slip_states(c[:, k], grid)[:, grid.index(float(slip[1]))]
        else:
            expected = friction[:, fr.TERMS.index(kind.removeprefix("friction."))]
        np.testing.assert_array_equal(column[:, k], expected)


@pytest.mark.slow
@needs_wpi
def test_wpi_selection_reads_only_the_training_file(monkeypatch, tmp_path):
    """--select on WPI files: the phase cross-validation sees only the training file's arrays,
    and the test file is opened only after the choice (a test file of NaNs fails afterwards,
    with the selection already made on the training data)."""
    loaded, chosen = [], []
    real_load, real_select = wpi.load_wpi, wpi_report.select_by_phase_cross_validation
    monkeypatch.setattr(wpi, "load_wpi", lambda p: loaded.append(Path(p)) or real_load(p))

    def spy(c, dc, tau, **kwargs):
        train = real_load(WPI_DIR / "one_results.csv")
        assert np.array_equal(c, train.q) and np.array_equal(tau, train.tau)
        out = real_select(c, dc, tau, **kwargs)
        chosen.append((out[0], list(loaded)))
        return out

    monkeypatch.setattr(wpi_report, "select_by_phase_cross_validation", spy)
    monkeypatch.setattr(wpi_report, "SELECTION_CANDIDATES", {
        "no hysteresis": DynamicsFitOptions(hysteresis_coordinates=()),
        "default": DynamicsFitOptions()})
    nan_test = tmp_path / "two_nan.csv"
    np.savetxt(nan_test, np.full((3000, 21), np.nan), delimiter=",")
    with pytest.raises(IdentificationInputError, match="non-finite"):
        fit_dynamics_cli(WPI_DIR / "one_results.csv", nan_test, "wpi", select=True, folds=2)
    assert len(chosen) == 1 and chosen[0][1] == [WPI_DIR / "one_results.csv"]
    assert loaded[-1] == nan_test  # opened after the choice
