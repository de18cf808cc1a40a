"""The user's path from ROS bags to a running estimator, end to end, as on a real robot: the
simulated bench writes one ROS 2 MCAP bag per trial on the dVRK CRTK topics (``simulate --format
mcap``), each bag is converted (``convert --r-ati-psm``), the folder indexed, the prior fitted, the
hybrid trained, streamed over a converted test recording and exported to ONNX. The converted
recordings must equal the simulator's CSV recordings of the same seed."""

import json

import numpy as np
import pandas as pd
import pytest
from rosbags.rosbag2 import Writer

from psmforce.estimators import StreamingEstimator
from psmforce.robot import PSM
from psmforce.io.bags import BagError, convert_bag
from psmforce.io.bags.writing import write_bag
from psmforce.io.recording import ATI_RAW, REQUIRED, TARGETS, read_recording
from psmforce.sim import SimulationConfigError, simulate
from psmforce.cli.main import main

SCALE = 0.005  # the protocol's floor: 20 trials, every split and condition (about 100 s of data)
SEED = 4
START_NS = 1_700_000_000 * 10**9
# The bag carries every stream at the recording's own sample instants, so the resampling lands on
# them: the only difference left is each CSV's rounding to 7 significant digits.
RTOL, ATOL = 1e-6, 1e-9


@pytest.fixture(scope="module")
def pipeline(tmp_path_factory):
    root = tmp_path_factory.mktemp("bag_pipeline")
    bags, conv = root / "bags", root / "converted"
    assert main(["simulate", "--scale", str(SCALE), "--seed", str(SEED), "--format", "mcap",
                 "--out", str(bags)]) == 0
    simulate("automated", scale=SCALE, seed=SEED, out=root / "csv")
    meta = json.loads((bags / "metadata.json").read_text())
    reports = {}
    for trial in meta["trials"]:
        out = conv / f"{trial['path']}.csv"
        out.parent.mkdir(parents=True, exist_ok=True)
        report = root / "reports" / f"{trial['path'].replace('/', '_')}.json"
        report.parent.mkdir(exist_ok=True)
        assert main(["convert", str(bags / trial["path"]), "--out", str(out), "--r-ati-psm",
                     str(bags / meta["bags"]["r_ati_psm"]), "--json", str(report)]) == 0
        reports[trial["path"]] = json.loads(report.read_text())
    assert main(["index", str(conv)]) == 0
    assert main(["fit-prior", "--data", str(conv), "--out", str(root / "prior.json"),
                 "--json", str(root / "prior_report.json")]) == 0
    assert main(["train", "--data", str(conv), "--model", "hybrid", "--prior",
                 str(root / "prior.json"), "--epochs", "1", "--out", str(root / "hybrid.pt")]) == 0
    assert main(["export", str(root / "hybrid.pt"), "--out", str(root / "onnx")]) == 0
    return root, meta, reports


@pytest.mark.slow
def test_bags_keep_the_dataset_layout_and_metadata(pipeline):
    root, meta, _ = pipeline
    csv_meta = json.loads((root / "csv" / "metadata.json").read_text())
    assert meta["format"] == "mcap" and csv_meta["format"] == "csv"
    assert [t["path"] + ".csv" for t in meta["trials"]] == [t["path"] for t in csv_meta["trials"]]
    strip = [{k: v for k, v in t.items() if k != "path"} for t in meta["trials"]]
    assert strip == [{k: v for k, v in t.items() if k != "path"} for t in csv_meta["trials"]]
    for trial in meta["trials"]:
        bag = root / "bags" / trial["path"]
        assert sorted(p.name for p in bag.iterdir()) == sorted(["metadata.yaml",
                                                                f"{bag.name}.mcap"])
    r_ati_psm = np.array(json.loads((root / "bags" / "R_ati_psm.json").read_text()))
    assert np.allclose(r_ati_psm, np.array(csv_meta["R_base_ati"]).T)
    assert not list((root / "bags").rglob("*.part"))


@pytest.mark.slow
def test_conversion_reads_every_stream_on_header_stamps_without_anomalies(pipeline):
    _, meta, reports = pipeline
    starts = []
    for trial in meta["trials"]:
        report = reports[trial["path"]]
        assert report["bag_kind"] == "ROS 2" and report["rows"] == trial["rows"]
        assert report["targets"].startswith("ati_fx, ati_fy, ati_fz by paper eq. 4")
        assert report["streams"]["jacobian"]["skipped"]
        for name, topic in meta["bags"]["topics"].items():
            stream = report["streams"][name]
            assert stream["topic"] == topic and stream["messages"] == trial["rows"]
            assert stream["time_source"] == "header" and not stream["gaps"]
            assert stream["out_of_order"] == stream["duplicates"] == stream["dropped_estimate"] == 0
        starts.append(report["start_time_s"])
    assert starts[0] == meta["bags"]["session_start_ns"] / 1e9 and np.all(np.diff(starts) > 0)


@pytest.mark.slow
def test_converted_recordings_equal_the_simulators_csv(pipeline):
    root, meta, _ = pipeline
    columns = list(REQUIRED + TARGETS + ATI_RAW)
    for trial in meta["trials"]:
        converted = read_recording(root / "converted" / f"{trial['path']}.csv",
                                   require_targets=True)
        simulated = read_recording(root / "csv" / f"{trial['path']}.csv", require_targets=True)
        assert len(converted) == len(simulated)
        np.testing.assert_array_equal(converted["time"], simulated["time"])
        np.testing.assert_allclose(converted[columns], simulated[columns], rtol=RTOL, atol=ATOL,
                                   err_msg=trial["path"])


@pytest.mark.slow
def test_index_fit_train_stream_and_export_on_the_converted_bags(pipeline):
    root, meta, _ = pipeline
    indexed = json.loads((root / "converted" / "metadata.json").read_text())["trials"]
    assert sorted((t["path"], t["condition"], t["split"]) for t in indexed) == sorted(
        (t["path"] + ".csv", t["condition"], t["split"]) for t in meta["trials"])
    assert json.loads((root / "prior_report.json").read_text())["converged"]
    estimator = StreamingEstimator.from_checkpoint(root / "hybrid.pt", post_filter="lowpass",
                                                   psm=PSM())
    test_trial = next(t for t in meta["trials"]
                      if t["split"] == "test" and t["condition"] == "Traction")
    streamed = {}
    for source in ("converted", "csv"):
        estimator.reset()
        recording = read_recording(root / source / f"{test_trial['path']}.csv")
        estimates = [estimator.step(sample, base_frame=True)
                     for sample in recording.to_dict("records")]
        streamed[source] = np.array([np.concatenate([e.force_hex10, e.force_base])
                                     for e in estimates])
    forces = streamed["converted"]
    assert forces.shape == (len(recording), 6) and np.isfinite(forces).all()
    # the same estimates as from the simulator's own CSV (inputs equal to 7 digits)
    np.testing.assert_allclose(forces, streamed["csv"], atol=1e-4)
    assert (root / "onnx" / "hybrid_step.onnx").stat().st_size > 0
    assert json.loads((root / "onnx" / "hybrid.json").read_text())["features"]


def _recording(rows=50, ati=True):
    rng = np.random.default_rng(0)
    columns = [c for c in REQUIRED if c != "time"] + (list(ATI_RAW) if ati else [])
    frame = pd.DataFrame(rng.standard_normal((rows, len(columns))) * 0.1, columns=columns)
    frame["insertion_position"] += 0.1
    frame.insert(0, "time", np.arange(rows) * 0.01)
    return frame


def test_write_bag_without_ati_and_convert_back(tmp_path):
    frame = _recording(ati=False)
    assert set(write_bag(frame, tmp_path / "b", start_ns=START_NS)) == {"js", "jaw", "hex10"}
    report = convert_bag(tmp_path / "b", tmp_path / "b.csv")
    assert report["streams"]["ati"]["skipped"] and report["rows"] == len(frame)
    back = read_recording(tmp_path / "b.csv")
    np.testing.assert_allclose(back[list(REQUIRED)], frame[list(REQUIRED)], rtol=RTOL, atol=ATOL)


def test_a_folder_named_like_a_staging_folder_is_not_the_writers(tmp_path):
    """Issue 46, class 1: a bag was staged in the fixed sibling ``NAME.part`` and refused to be
    written beside the user's folder of that name; a link in the bag's place is not replaced."""
    theirs = tmp_path / "b.part"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("the user's")
    write_bag(_recording(), tmp_path / "b", start_ns=START_NS)
    assert (tmp_path / "b" / "metadata.yaml").is_file()
    assert [p.name for p in theirs.iterdir()] == ["notes.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b", "b.part"]   # no staging left
    (tmp_path / "link").symlink_to(tmp_path / "nowhere")  # dangling: exists() says False
    with pytest.raises(BagError, match="exists already"):
        write_bag(_recording(), tmp_path / "link", start_ns=START_NS)
    assert (tmp_path / "link").is_symlink()


@pytest.mark.parametrize("change, message", [
    (lambda f: f.drop(columns="jaw_effort"), r"lacks columns \['jaw_effort'\]"),
    (lambda f: f.assign(time=0.0), "strictly increasing"),
])
def test_write_bag_refuses_a_bad_recording_naming_the_bag(tmp_path, change, message):
    with pytest.raises(BagError, match=message) as err:
        write_bag(change(_recording()), tmp_path / "b", start_ns=START_NS)
    assert str(tmp_path / "b") in str(err.value)
    assert not list(tmp_path.iterdir())


def test_write_bag_leaves_nothing_when_writing_fails(tmp_path, monkeypatch):
    def broken(self, connection, timestamp, data):
        raise OSError("disk full")
    monkeypatch.setattr(Writer, "write", broken)
    with pytest.raises(OSError, match="disk full"):
        write_bag(_recording(), tmp_path / "b", start_ns=START_NS)
    assert not list(tmp_path.iterdir())


def test_write_bag_refuses_an_existing_bag_and_simulate_an_unknown_format(tmp_path):
    (tmp_path / "b").mkdir()
    with pytest.raises(BagError, match="exists already"):
        write_bag(_recording(), tmp_path / "b", start_ns=START_NS)
    with pytest.raises(SimulationConfigError, match="fmt: unknown 'rosbag1'"):
        simulate("automated", scale=SCALE, out=tmp_path / "s", fmt="rosbag1")
    assert not (tmp_path / "s").exists()
