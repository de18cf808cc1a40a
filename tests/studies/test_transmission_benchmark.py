"""studies/transmission.py --quick on the real MRD Lab files (skipped where they are absent):
the JSON's structure, finite metrics, and the physics model beating a constant predictor."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.slow, pytest.mark.e2e]  # one run of the study on real recordings
ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "mrdlab"


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    if not (DATA / "Tool_4_Maryland_L_4").is_dir():
        pytest.skip(f"MRD Lab transmission data not found at {DATA}")
    out = tmp_path_factory.mktemp("transmission")
    subprocess.run([sys.executable, str(ROOT / "studies" / "transmission.py"), "--quick",
                    "--data", str(DATA), "--json", str(out / "t.json"), "--work",
                    str(out / "work"), "--seeds", "1", "--models", "physics", "fcn", "hybrid"],
                   check=True, cwd=ROOT, timeout=300)
    return json.loads((out / "t.json").read_text()), out


def test_structure_and_finite_metrics(quick_run):
    result, out = quick_run
    assert result["quick"] and (out / "t.txt").exists()
    protocols = {"a_held_out_files", "b_other_session", "c_other_tool_as_is",
                 "c_other_tool_calibrated"}
    assert set(result["summary"]) == protocols
    assert {(r["model"], r["protocol"]) for r in result["records"]} == {
        (m, p) for m in ("physics", "fcn", "hybrid") for p in protocols}
    for r in result["records"]:
        for part in ("whole", "closing"):
            for k in ("torque_rmse_mNm", "angle_rmse_deg", "torque_nrmse_pct",
                      "angle_nrmse_pct"):
                assert math.isfinite(r["metrics"][part][k]) and r["metrics"][part][k] >= 0
        if r["model"] != "physics":
            assert isinstance(r["fit"]["converged"], bool) and r["fit"]["epochs_run"] >= 1
    assert set(result["verdicts"]["a_held_out_files"]["whole"]["torque_rmse_mNm"]) >= {
        "best", "runner_up", "verdict"}
    assert result["physics"]["deterministic"] is True


def test_physics_beats_a_constant(quick_run):
    """The physics' torque and angle RMSE on (a)'s test file is below that of a constant
    predictor: the training files' mean."""
    from psmforce.identification.transmission.recording import home_session, read_transmission_file
    result, _ = quick_run
    folder = DATA / "Tool_4_Maryland_L_4"
    sp = result["splits"]
    names = sorted({"00", *sp["a_train"], *sp["a_val"], *sp["a_test"]})
    recs = {r.name[-2:]: r for r in home_session([read_transmission_file(folder / f"{n}.TXT")
                                                  for n in names])}
    phys = result["summary"]["a_held_out_files"]["physics"]["whole"]
    for key, metric, unit in (("jaw_torque_nm", "torque_rmse_mNm", 1e3),
                              ("jaw_angle_rad", "angle_rmse_deg", np.degrees(1.0))):
        constant = np.concatenate([getattr(recs[n], key) for n in sp["a_train"]]).mean()
        truth = np.concatenate([getattr(recs[n], key) for n in sp["a_test"]])
        assert phys[metric]["mean"] < unit * np.sqrt(np.mean((truth - constant) ** 2)), metric
