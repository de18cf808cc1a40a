"""``psmforce excitation``: the setpoint CSV and the ROS 2 bag read back, the report, and bad
arguments refused in one line with nothing left behind."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from psmforce.cli.main import main
from psmforce.io.bags.messages import ROS2_TYPESTORE
from psmforce.sim.excitation import DT, read_setpoints, simulate_excitation


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("excitation") / "out"
    assert main(["excitation", "--out", str(out), "--minutes", "0.3", "--seed", "4"]) == 0
    return out


def test_the_csv_the_bag_and_the_report_agree(written):
    q, dt = read_setpoints(written / "excitation.csv")
    assert dt == pytest.approx(DT)
    report = json.loads((written / "excitation.json").read_text())
    assert report["samples"] == len(q)
    assert report["files"]["topics"] == {"js": "/PSM1/servo_jp", "jaw": "/PSM1/jaw/servo_jp"}
    got = {"/PSM1/servo_jp": [], "/PSM1/jaw/servo_jp": []}
    stamps = {k: [] for k in got}
    with Reader(written / "excitation_bag") as reader:
        for conn, _, raw in reader.messages():
            msg = ROS2_TYPESTORE.deserialize_cdr(raw, conn.msgtype)
            assert conn.msgtype == "sensor_msgs/msg/JointState"
            got[conn.topic].append(msg.position.copy())
            stamps[conn.topic].append(msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec)
        names = {c.topic: c.msgtype for c in reader.connections}
    assert set(names) == set(got)
    assert np.vstack(got["/PSM1/servo_jp"]) == pytest.approx(q[:, :6], abs=1e-8)
    assert np.vstack(got["/PSM1/jaw/servo_jp"])[:, 0] == pytest.approx(q[:, 6], abs=1e-8)
    assert np.diff(stamps["/PSM1/servo_jp"]) == pytest.approx(DT * 1e9, abs=1)
    assert sorted(p.name for p in written.iterdir()) == ["excitation.csv", "excitation.json",
                                                         "excitation_bag"]


def test_the_bench_runs_the_written_setpoints(written):
    q, dt = read_setpoints(written / "excitation.csv")
    frame = simulate_excitation(q, dt=dt, seed=0)
    assert len(frame) == len(q) and frame["jaw_effort"].min() < -0.004  # a clench shows
    assert frame["hex10_overload"].max() == 0


@pytest.mark.parametrize("argv", [
    ["--minutes", "0.1"], ["--minutes", "nan"], ["--known-weights", "5"], ["--seed", "-3"]])
def test_bad_arguments_are_refused_in_one_line_and_leave_nothing(argv, tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) if argv[0] != "--seed" else _returns(2):
        main(["excitation", "--out", str(out), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("psmforce excitation: error:") and argv[0] in err[-1]
    assert "Traceback" not in "\n".join(err)
    assert not out.exists()


class _returns:
    """A context for a main() call that returns its exit code instead of raising."""

    def __init__(self, code):
        self.code = code

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_a_non_empty_or_file_out_is_refused_before_the_work(tmp_path, cli_error):
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("mine")
    assert main(["excitation", "--out", str(full), "--minutes", "0.3"]) == 2
    assert "not empty" in cli_error("excitation")
    assert sorted(p.name for p in full.iterdir()) == ["keep.txt"]
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert main(["excitation", "--out", str(a_file), "--minutes", "0.3"]) == 2
    assert "not a folder" in cli_error("excitation")
    assert a_file.read_text() == "x"
    long = tmp_path / ("e" * 300)
    assert main(["excitation", "--out", str(long), "--minutes", "0.3"]) == 2
    assert "--out" in cli_error("excitation")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "full"]


def test_an_out_that_is_a_link_is_refused_and_not_written_through(tmp_path, cli_error):
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "link").symlink_to(real)
    assert main(["excitation", "--out", str(tmp_path / "link"), "--minutes", "0.3"]) == 2
    assert "symbolic link" in cli_error("excitation")
    assert list(real.iterdir()) == []


def test_paired_poses_need_known_weights(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["excitation", "--out", str(out), "--minutes", "0.3", "--paired-poses"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--paired-poses: only with --known-weights" in err[0]
    assert not out.exists() or not any(out.iterdir())
