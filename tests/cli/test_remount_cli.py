"""``psmforce remount`` (issue 44, item 4; psmforce/estimators/training/remount.py): after a
re-mount, only the per-mount values of a hybrid's prior move, into a new checkpoint that loads
and evaluates as any other; the input is never written; bad input is one line, exit 2, nothing
written."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np
import pytest
import torch

from psmforce.cli.main import main
from psmforce.estimators.data.hybrid_inputs import hybrid_columns, prior_to_json
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.training import checkpoint as ck
from psmforce.identification.prior import NAMES, InternalForcePrior
from psmforce.identification.prior_remount import FORCE_PER_MOUNT
from psmforce.io.recording import write_recording
from tests.estimators.test_streaming import INSERTION, model_and_scalers

CONFIG = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}
SECONDS = 40.0
"""Free space of the re-mounted tool: shorter than the procedure's two minutes (the command
notes it), long enough for the recalibration's checks (roll, samples)."""


@functools.lru_cache(maxsize=None)
def _simulated(seed: int, remount_seed: int = 1):
    """``SECONDS`` of the paper's free-space motion on the default bench's tool re-mounted by
    ``Remount.draw(remount_seed)`` (as studies/remount.py simulates it); a cached frame, not to
    be changed in place."""
    from psmforce.sim import protocols
    from psmforce.sim.bench import run_trajectory
    from psmforce.sim.mounting import Remount
    from psmforce.sim.params import Effects, InstrumentParams
    plan = protocols._random_free(1000 + seed, 0, SECONDS)
    tool = Remount.draw(remount_seed).apply(InstrumentParams())
    return run_trajectory(plan.q, protocols.DT, plan.contact, tool, Effects(),
                          np.random.default_rng([seed, 100, 0]), r_base_ati=protocols.R_BASE_ATI)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A hybrid checkpoint (the design-value prior with an insertion model, a small network,
    Fy answered by the prior alone), a folder with one free-space recording of the re-mounted
    tool (CSV directly in it), and a test set of another recording of it."""
    root = tmp_path_factory.mktemp("remount")
    torch.set_num_threads(1)
    features, base = hybrid_columns(True)
    model, xs, ys = model_and_scalers(len(features))
    ckpt = ck.TrainedModel("hybrid", CONFIG, features, xs, ys, base, model=model,
                           derivation="prior",
                           prior_json=prior_to_json(InternalForcePrior(converged=True,
                                                                       insertion=INSERTION)),
                           provenance={"seed": 3},
                           physics_only_axes=("Fy",)).save(root / "tool.pt")
    _write(_simulated(1), root / "mount2" / "excitation.csv")
    _write(_simulated(2), root / "heldout" / "test" / "Free" / "free_0.csv")
    assert main(["index", str(root / "heldout")]) == 0
    return root, ckpt


def _write(frame, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_recording(frame, path)


def _files(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_only_the_per_mount_values_move_into_a_new_checkpoint(lab, tmp_path, capsys):
    root, ckpt = lab
    before = ckpt.read_bytes()
    out, report = tmp_path / "tool_mount2.pt", tmp_path / "remount.json"
    assert main(["remount", str(ckpt), "--data", str(root / "mount2"), "--out", str(out),
                 "--json", str(report)]) == 0
    printed = capsys.readouterr().out
    assert ckpt.read_bytes() == before                        # the input, byte for byte
    for name in FORCE_PER_MOUNT:
        assert f"  {name} " in printed and " -> " in printed
    assert "held at the checkpoint's values: pulley_radius_pitch" in printed
    assert "bias_tx, bias_ty, bias_tz" in printed and f"wrote {out}" in printed
    assert "min of recordings; the procedure records 2 min" in printed  # shorter: said

    old, new = ck.load_checkpoint(ckpt), ck.load_checkpoint(out)
    p_old, p_new = old.prior(), new.prior()
    moved = {n for n, a, b in zip(NAMES, p_old.params, p_new.params) if a != b}
    assert "pretension_total" in moved and moved <= set(FORCE_PER_MOUNT)
    assert np.array_equal(p_old.axis_weights, p_new.axis_weights)
    assert p_new.insertion.to_dict() == p_old.insertion.to_dict()
    assert new.features == old.features and new.base_columns == old.base_columns
    assert new.physics_only_axes == old.physics_only_axes == ("Fy",)   # a re-mount keeps them
    assert new.input_scaler.to_dict() == old.input_scaler.to_dict()
    assert new.target_scaler.to_dict() == old.target_scaler.to_dict()
    s_old, s_new = old.model.state_dict(), new.model.state_dict()
    assert s_old.keys() == s_new.keys() and all(torch.equal(s_old[k], s_new[k]) for k in s_old)

    record = new.provenance["remounts"][-1]
    assert new.provenance["seed"] == 3 and len(new.provenance["remounts"]) == 1
    assert record["re_estimated"] == list(FORCE_PER_MOUNT)
    assert set(record["held"]) == set(NAMES) - set(FORCE_PER_MOUNT)
    assert record["after"] == {n: float(p_new.params[NAMES.index(n)]) for n in FORCE_PER_MOUNT}
    assert [r["path"] for r in record["recordings"]] == ["excitation.csv"]
    assert json.loads(report.read_text())["after"] == pytest.approx(record["after"])

    # it streams and evaluates like any other checkpoint, with the new prior
    frame = _simulated(2)
    est_old = StreamingEstimator.from_checkpoint(ckpt).predict_recording(frame.iloc[:300])
    est_new = StreamingEstimator.from_checkpoint(out).predict_recording(frame.iloc[:300])
    assert np.isfinite(est_new).all() and not np.allclose(est_old, est_new)
    assert main(["evaluate", str(out), "--data", str(root / "heldout"),
                 "--out", str(tmp_path / "eval")]) == 0
    assert (tmp_path / "eval" / "metrics.md").is_file()

    # a second re-mount: from the recalibrated checkpoint, the record appended
    again = tmp_path / "tool_mount3.pt"
    assert main(["remount", str(out), "--data", str(root / "mount2" / "excitation.csv"),
                 "--out", str(again)]) == 0
    assert len(ck.load_checkpoint(again).provenance["remounts"]) == 2


@pytest.fixture(scope="module")
def bad(lab, tmp_path_factory):
    """Inputs a re-mount refuses: a checkpoint without a prior, a recording too short, one under
    load, a folder with no free-space recording, a file that is no checkpoint."""
    d = tmp_path_factory.mktemp("bad")
    features, base = hybrid_columns(False)
    model, xs, ys = model_and_scalers(len(features))
    ck.TrainedModel("hybrid", CONFIG, features, xs, ys, base, model=model,
                    provenance={"seed": 3}).save(d / "no_prior.pt")
    frame = _simulated(1)
    _write(frame.iloc[:150], d / "short.csv")
    _write(frame.assign(ati_fx=2.0), d / "loaded.csv")  # a fixture left on the tool
    _write(frame.iloc[:150], d / "traction" / "train" / "Traction" / "t.csv")
    (d / "taken.pt").write_bytes(b"the user's file")
    return d


BAD = {
    "a missing folder": (lambda r, d: ["CKPT", "--data", str(d / "nowhere")],
                         "no such recording"),
    "no free-space recording": (lambda r, d: ["CKPT", "--data", str(d / "traction")],
                                "no free-space recordings: found conditions ['Traction']"),
    "too few samples": (lambda r, d: ["CKPT", "--data", str(d / "short.csv")],
                        "150 usable samples is too short"),
    "a recording under load": (lambda r, d: ["CKPT", "--data", str(d / "loaded.csv")],
                               "carry an external force"),
    "a checkpoint without a prior": (lambda r, d: [str(d / "no_prior.pt"), "--data",
                                                   str(r / "mount2")],
                                     "without an internal-force prior"),
    "an existing output": (lambda r, d: ["CKPT", "--data", str(r / "mount2"), "--out",
                                         str(d / "taken.pt")], "exists: a re-mount writes a new"),
    "the input as output": (lambda r, d: ["CKPT", "--data", str(r / "mount2"), "--out",
                                          str(r / "tool.pt")], "write over an input"),
    "a corrupt checkpoint": (lambda r, d: [str(d / "taken.pt"), "--data", str(r / "mount2")],
                             "not a psmforce checkpoint"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_one_line_exit_2_and_writes_nothing(lab, bad, tmp_path, cli_error, case):
    root, ckpt = lab
    argv, expected = BAD[case]
    args = [str(ckpt) if a == "CKPT" else a for a in argv(root, bad)]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "new.pt")]
    before = [_files(f) for f in (root, bad, tmp_path)]
    assert main(["remount", *args]) == 2
    assert expected in cli_error("remount")
    assert [_files(f) for f in (root, bad, tmp_path)] == before  # nothing written, nothing left


def test_the_command_explains_itself(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["remount", "--help"])
    assert exit_.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert text.startswith("usage: psmforce remount")
    for phrase in ("cable pretension", "three HEX10 force offsets", "NEW checkpoint",
                   "no overwrite option", "psmforce excitation --minutes 2"):
        assert phrase in text
