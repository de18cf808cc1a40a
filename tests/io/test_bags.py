"""Bag conversion: small dVRK bags written here (ROS 2 MCAP, ROS 2 sqlite3, ROS 1), converted, and
the CSV checked against interpolations computed in this file from the values that were written."""

from __future__ import annotations

import bisect
import json
from dataclasses import dataclass, field

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from psmforce.robot import PSM
from psmforce.io.bags import BagError, convert_bag, convert_csv, load_column_map, summary_line
from psmforce.io.recording import ATI_RAW, HEX10, JOINTS, RecordingError, read_recording

EPOCH_NS = 1_700_000_000 * 10**9
MS = 1_000_000
ARM = JOINTS[:6]
NEW_NAMES = ["pitch", "yaw", "insertion", "wrist_yaw", "roll", "wrist_pitch"]  # not dVRK order
OLD_NAMES = ["outer_" + n for n in NEW_NAMES]
TOPICS = {"js": "/PSM1/measured_js", "jaw": "/PSM1/jaw/measured_js",
          "hex10": "/hex10/measured_cf", "ati": "/ati/measured_cf"}
WRENCH = {"hex10": HEX10, "ati": ATI_RAW}
JACOBIAN = [f"spatial_jacobian_{r}{c}" for r in range(6) for c in range(6)]
GAP_MS = (400, 520)  # hex10 messages strictly between these are never written
OUT_OF_ORDER = 50    # js message 50 is written after message 51
DUPLICATE = 30       # jaw message 30 is written twice, the second copy with other values


STORAGES = pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3],
                                   ids=["mcap", "sqlite3"])


@dataclass
class Message:
    stream: str
    stamp_ns: int    # header stamp (0 = unset)
    log_ns: int      # bag receive time
    values: dict[str, float]


@dataclass
class Bench:
    """What went into a bag: the messages in bag order, and each stream's true samples."""

    messages: list[Message] = field(default_factory=list)
    truth: dict[str, list[tuple[int, dict[str, float]]]] = field(default_factory=dict)


def _signal(rng, columns):
    """A smooth random signal per column (amplitude, angular rate, phase); chain joint positions
    stay inside the joint limits (insertion 0.12 +- 0.11 m, angles within +-0.66 rad)."""
    params = {c: rng.uniform([0.1, 2.0, 0.0], [2.0, 12.0, 6.0]) for c in columns}
    scale = {c: 0.05 if c == "insertion_position" else 0.3 if c.endswith("_position") else 1.0
             for c in columns}
    offset = {c: 0.12 if c == "insertion_position" else 0.0 for c in columns}
    return lambda t: {c: offset[c] + scale[c] * a * (np.sin(w * t + p) + 0.1)
                      for c, (a, w, p) in params.items()}


def _bench(seed=0, jaw_zero_stamps=False, jacobian=False):
    """dVRK bench streams: js 200 Hz, jaw 200 Hz (2.5 ms later), hex10 250 Hz with a gap,
    ATI 500 Hz, optionally the spatial Jacobian at 100 Hz (no header: bag time); 1 ms receive
    latency; one out-of-order js message and one duplicate jaw stamp."""
    rng = np.random.default_rng(seed)
    js_cols = [f"{j}_{f}" for f in ("position", "velocity", "effort") for j in ARM]
    jaw_cols = ["jaw_position", "jaw_velocity", "jaw_effort"]
    plan = {"js": (0, 5, 201, js_cols), "jaw": (2.5, 5, 200, jaw_cols),
            "hex10": (10, 4, 248, WRENCH["hex10"]), "ati": (1, 2, 500, WRENCH["ati"])}
    if jacobian:
        plan["jacobian"] = (0.5, 10, 100, JACOBIAN)
    bench = Bench()
    for stream, (first_ms, period_ms, count, cols) in plan.items():
        signal = _signal(rng, cols)
        samples = []
        for k in range(count):
            t_ms = first_ms + k * period_ms
            if stream == "hex10" and GAP_MS[0] < t_ms < GAP_MS[1]:
                continue
            stamp = EPOCH_NS + int(round(t_ms * MS))
            samples.append((stamp, signal(t_ms / 1e3)))
        zero = (stream == "jaw" and jaw_zero_stamps) or stream == "jacobian"
        bench.truth[stream] = [(s + MS if zero else s, v) for s, v in samples]
        for i, (stamp, values) in enumerate(samples):
            log = stamp + MS
            if stream == "js" and i == OUT_OF_ORDER:
                log = samples[i + 1][0] + MS + 1000
            bench.messages.append(Message(stream, 0 if zero else stamp, log, values))
            if stream == "jaw" and i == DUPLICATE:
                bench.messages.append(Message(stream, 0 if zero else stamp, log + 10,
                                              {c: v + 5.0 for c, v in values.items()}))
    bench.messages.sort(key=lambda m: m.log_ns)
    return bench


def _msgs(typestore, ros1):
    """Message constructors for one typestore."""
    T = typestore.types
    Time = T["builtin_interfaces/msg/Time"]

    def header(stamp_ns):
        stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        if ros1:
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="")
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="")

    def joint_state(stamp_ns, names, values, aliases):
        ours = [aliases[n] for n in names]
        fields = {f: np.array([values.get(f"{j}_{f}", 0.0) for j in ours])
                  for f in ("position", "velocity", "effort")}
        return T["sensor_msgs/msg/JointState"](header=header(stamp_ns), name=list(names), **fields)

    def wrench(stamp_ns, v):
        V = T["geometry_msgs/msg/Vector3"]
        return T["geometry_msgs/msg/WrenchStamped"](
            header=header(stamp_ns),
            wrench=T["geometry_msgs/msg/Wrench"](force=V(x=v[0], y=v[1], z=v[2]),
                                                 torque=V(x=v[3], y=v[4], z=v[5])))
    return joint_state, wrench


def _jacobian_message(store, values):
    T = store.types
    dim = T["std_msgs/msg/MultiArrayDimension"]
    layout = T["std_msgs/msg/MultiArrayLayout"](
        dim=[dim(label="row", size=6, stride=36), dim(label="column", size=6, stride=6)],
        data_offset=0)
    return T["std_msgs/msg/Float64MultiArray"](layout=layout,
                                               data=np.array([values[c] for c in JACOBIAN]))


def _message(joint_state, wrench, message, arm_names):
    if message.stream == "js":
        aliases = {n: n.removeprefix("outer_") for n in arm_names}
        msg = joint_state(message.stamp_ns, arm_names, message.values, aliases)
        return "sensor_msgs/msg/JointState", msg
    if message.stream == "jaw":
        return "sensor_msgs/msg/JointState", joint_state(message.stamp_ns, ["jaw"], message.values,
                                                         {"jaw": "jaw"})
    cols = WRENCH[message.stream]
    return "geometry_msgs/msg/WrenchStamped", wrench(message.stamp_ns,
                                                     [message.values[c] for c in cols])


def write_ros2(path, bench, storage, arm_names=NEW_NAMES, topics=TOPICS):
    store = get_typestore(Stores.ROS2_HUMBLE)
    joint_state, wrench = _msgs(store, ros1=False)
    with Writer2(path, version=9, storage_plugin=storage) as writer:
        wrench_type = "geometry_msgs/msg/WrenchStamped"
        types = {"js": "sensor_msgs/msg/JointState", "jaw": "sensor_msgs/msg/JointState",
                 "hex10": wrench_type, "ati": wrench_type,
                 "jacobian": "std_msgs/msg/Float64MultiArray"}
        conns = {s: writer.add_connection(t, types[s], typestore=store) for s, t in topics.items()}
        for m in bench.messages:
            if m.stream == "jacobian" and m.stream in conns:
                msgtype, msg = types["jacobian"], _jacobian_message(store, m.values)
                writer.write(conns[m.stream], m.log_ns, store.serialize_cdr(msg, msgtype))
            elif m.stream in conns:
                msgtype, msg = _message(joint_state, wrench, m, arm_names)
                writer.write(conns[m.stream], m.log_ns, store.serialize_cdr(msg, msgtype))
    return path


def write_ros1(path, bench, arm_names=OLD_NAMES):
    store = get_typestore(Stores.ROS1_NOETIC)
    joint_state, wrench = _msgs(store, ros1=True)
    with Writer1(path) as writer:
        conns = {}
        for s, t in TOPICS.items():
            msgtype = "sensor_msgs/msg/JointState" if s in ("js", "jaw") else \
                "geometry_msgs/msg/WrenchStamped"
            conns[s] = writer.add_connection(t, msgtype, typestore=store)
        for m in bench.messages:
            msgtype, msg = _message(joint_state, wrench, m, arm_names)
            writer.write(conns[m.stream], m.log_ns, store.serialize_ros1(msg, msgtype))
    return path


def expected(bench, rate_hz=100.0):
    """Output times (s) and interpolated columns from the true samples, gap rows removed."""
    truth = bench.truth
    start = max(s[0][0] for s in truth.values())
    end = min(s[-1][0] for s in truth.values())
    count = int((end - start) * rate_hz / 1e9) + 1
    times_ns = [start + round(k * 1e9 / rate_hz) for k in range(count)]  # ints: exact at 1.7e18 ns
    hex_stamps = [s for s, _ in truth["hex10"]]
    lo = max(s for s in hex_stamps if s < EPOCH_NS + GAP_MS[0] * MS)
    hi = min(s for s in hex_stamps if s > EPOCH_NS + GAP_MS[1] * MS)
    times_ns = [t for t in times_ns if not lo < t < hi]
    columns = {"time": [(t - start) / 1e9 for t in times_ns]}
    for samples in truth.values():
        stamps = [s for s, _ in samples]
        for col in samples[0][1]:
            out = []
            for t in times_ns:
                i = min(bisect.bisect_right(stamps, t) - 1, len(stamps) - 2)
                (s0, v0), (s1, v1) = samples[i], samples[i + 1]
                out.append(v0[col] + (v1[col] - v0[col]) * (t - s0) / (s1 - s0))
            columns[col] = out
    return columns


def check_csv(path, bench):
    frame = read_recording(path)
    want = expected(bench)
    assert len(frame) == len(want["time"])
    for col, values in want.items():
        np.testing.assert_allclose(frame[col].to_numpy(), values, rtol=2e-6, atol=1e-6,
                                   err_msg=col)
    return frame


@STORAGES
def test_ros2_bag_converts_to_the_values_written(tmp_path, storage):
    bench = _bench(seed=1)
    bag = write_ros2(tmp_path / "bag", bench, storage)
    out = tmp_path / "rec.csv"
    report = convert_bag(bag, out)
    frame = check_csv(out, bench)
    assert (frame["time"].diff() > 0.0101).sum() == 1  # time jumps once: over the dropped rows
    streams = report["streams"]
    assert streams["js"]["out_of_order"] == 1 and streams["js"]["messages"] == 201
    assert streams["jaw"]["duplicates"] == 1 and streams["jaw"]["messages"] == 201
    assert [streams[n]["time_source"] for n in TOPICS] == ["header"] * 4
    (gap,) = streams["hex10"]["gaps"]
    assert gap["start_s"] == pytest.approx(0.388) and gap["end_s"] == pytest.approx(0.512)
    assert streams["hex10"]["dropped_estimate"] == 30  # 402 .. 518 ms, every 4 ms
    assert report["rows_in_gaps"] == 13 and report["rows"] == len(frame) == 99 - 13
    assert all(not streams[n]["gaps"] for n in ("js", "jaw", "ati"))
    assert "skipped" in streams["jacobian"]
    line = summary_line(report)
    assert "\n" not in line and "86 rows" in line and "1 gap(s), 13 row(s) dropped" in line
    json.dumps(report)  # the CLI writes it as JSON


def test_mcap_file_path_old_joint_names_and_bag_time_fallback(tmp_path):
    bench = _bench(seed=2, jaw_zero_stamps=True)
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.MCAP, arm_names=OLD_NAMES)
    (mcap,) = bag.glob("*.mcap")
    out = tmp_path / "rec.csv"
    report = convert_bag(mcap, out)
    check_csv(out, bench)
    jaw = report["streams"]["jaw"]
    assert jaw["time_source"] == "bag" and jaw["zero_header_stamps"] == 201
    assert "bag time for jaw" in summary_line(report)


def test_spatial_jacobian_stream_uses_bag_time(tmp_path):
    bench = _bench(seed=7, jacobian=True)
    topics = dict(TOPICS, jacobian="/PSM1/spatial/jacobian")
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.SQLITE3, topics=topics)
    report = convert_bag(bag, tmp_path / "rec.csv")
    check_csv(tmp_path / "rec.csv", bench)  # includes the 36 spatial_jacobian_* columns
    jacobian = report["streams"]["jacobian"]
    assert jacobian["time_source"] == "bag" and jacobian["messages"] == 100


def _rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


@pytest.mark.parametrize("ati_sign", [-1.0, 1.0])
def test_ati_targets_are_paper_eq4_in_the_hex10_frame(tmp_path, ati_sign):
    bench = _bench(seed=8)
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.MCAP)
    r_ati_psm = _rotation(np.random.default_rng(8))
    report = convert_bag(bag, tmp_path / "rec.csv", r_ati_psm=r_ati_psm, ati_sign=ati_sign)
    frame = read_recording(tmp_path / "rec.csv", require_targets=True)
    want = expected(bench)
    q = np.column_stack([want[f"{j}_position"] for j in ARM])
    f_ati = np.column_stack([want[c] for c in WRENCH["ati"][:3]])
    # eq. 4 written out: F' = sign [R_ati_PSM R_PSM_HEX10(q)]^T F_ATI, R_PSM_HEX10 from the model
    r_psm_hex10 = PSM().rotation(q, "hex10")
    f_hex10 = ati_sign * np.einsum("nji,jk,nk->ni", r_psm_hex10, r_ati_psm.T, f_ati)
    got = frame[["ati_fx", "ati_fy", "ati_fz"]].to_numpy()
    np.testing.assert_allclose(got, f_hex10, rtol=1e-5, atol=1e-5)
    assert np.allclose(np.linalg.norm(got, axis=1), np.linalg.norm(f_ati, axis=1), atol=1e-5)
    assert "eq. 4" in report["targets"]


def test_ros1_bag(tmp_path):
    bench = _bench(seed=3)
    out = tmp_path / "rec.csv"
    report = convert_bag(write_ros1(tmp_path / "rec.bag", bench), out)
    check_csv(out, bench)
    assert report["bag_kind"] == "ROS 1" and report["streams"]["js"]["out_of_order"] == 1


def test_flagged_gap_rows_are_kept_and_marked(tmp_path):
    bench = _bench(seed=4)
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.SQLITE3)
    out = tmp_path / "rec.csv"
    report = convert_bag(bag, out, on_gap="flag", rate_hz=50.0)
    frame = read_recording(out)
    assert len(frame) == report["rows"] == 50  # 0 .. 0.98 s every 20 ms
    flagged = frame.loc[frame["in_gap"] == 1, "time"].to_numpy()
    np.testing.assert_allclose(flagged, np.arange(0.40, 0.511, 0.02), atol=1e-9)


def test_topic_override_and_optional_ati(tmp_path):
    bench = _bench(seed=5)
    topics = dict(TOPICS, hex10="/hex/wrench")
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.MCAP, topics=topics)
    out = tmp_path / "rec.csv"
    with pytest.raises(BagError, match=r"topic '/hex10/measured_cf' \(hex10 stream\) not in"):
        convert_bag(bag, out)
    report = convert_bag(bag, out, topics={"hex10": "/hex/wrench", "ati": None})
    assert "skipped" in report["streams"]["ati"]
    assert "ati_raw_fx" not in read_recording(out).columns


# --- errors: one clear message, no output file ------------------------------------------------

def _no_output(tmp_path, call, match):
    out = tmp_path / "rec.csv"
    with pytest.raises(BagError, match=match):
        call(out)
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_missing_topic_names_it_and_lists_present(tmp_path):
    bench = _bench()
    bench.messages = [m for m in bench.messages if m.stream != "jaw"]
    topics = {k: v for k, v in TOPICS.items() if k != "jaw"}
    bag = write_ros2(tmp_path / "bag", bench, StoragePlugin.SQLITE3, topics=topics)
    _no_output(tmp_path, lambda out: convert_bag(bag, out),
               r"topic '/PSM1/jaw/measured_js' \(jaw stream\) not in the bag; topics present: "
               r"\['/PSM1/measured_js', '/ati/measured_cf', '/hex10/measured_cf'\]")
    _no_output(tmp_path, lambda out: convert_bag(bag, out, topics={"jaw": "/PSM2/jaw"}),
               r"topic '/PSM2/jaw' \(jaw stream\) not in the bag")


@STORAGES
def test_empty_bag(tmp_path, storage):
    bench = Bench(messages=[])
    bag = write_ros2(tmp_path / "bag", bench, storage)
    _no_output(tmp_path, lambda out: convert_bag(bag, out), "the bag is empty")


def test_bad_options(tmp_path):
    bag = write_ros2(tmp_path / "bag", _bench(), StoragePlugin.MCAP)
    for kwargs, match in [({"rate_hz": 0}, "rate_hz must be in \\(0, "),
                          ({"on_gap": "keep"}, "on_gap must be 'drop' or 'flag'"),
                          ({"topics": {"js": None}}, "stream 'js' is required"),
                          ({"topics": {"ati": "/hex10/measured_cf"}}, "one topic serves several"),
                          ({"r_ati_psm": np.diag([1.0, 1.0, -1.0])},
                           "ATI calibration: R_ati_psm is not a proper rotation"),
                          ({"r_ati_psm": np.eye(2)}, r"ATI calibration: R_ati_psm must have shape"),
                          ({"r_ati_psm": np.eye(3), "ati_sign": 0.5}, r"sign must be \+1 or -1")]:
        _no_output(tmp_path, lambda out: convert_bag(bag, out, **kwargs), match)
    _no_output(tmp_path, lambda out: convert_bag(bag, tmp_path / "no" / "rec.csv"),
               "output folder .* does not exist")


def test_unreadable_files(tmp_path):
    rng = np.random.default_rng(0)
    for name in ("junk.mcap", "junk.db3", "junk.bag"):
        (tmp_path / name).write_bytes(rng.bytes(4096))
        _no_output(tmp_path, lambda out: convert_bag(tmp_path / name, out),
                   "cannot read as a ROS 1 or ROS 2 bag")
    (tmp_path / "folder").mkdir()
    _no_output(tmp_path, lambda out: convert_bag(tmp_path / "folder", out),
               "cannot read as a ROS 1 or ROS 2 bag")
    _no_output(tmp_path, lambda out: convert_bag(tmp_path / "absent.mcap", out), "no such file")


def test_truncated_bag_is_unreadable(tmp_path):
    bag = write_ros2(tmp_path / "bag", _bench(), StoragePlugin.MCAP)
    (mcap,) = bag.glob("*.mcap")
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    _no_output(tmp_path, lambda out: convert_bag(bag, out), "cannot read as a ROS 1 or ROS 2 bag")


def test_unknown_and_missing_joint_names(tmp_path):
    names = ["pitch", "yaw", "insertion", "wrist_yaw", "roll", "wrist_pitch", "elbow"]
    bag = write_ros2(tmp_path / "bag", _bench(), StoragePlugin.MCAP, arm_names=names)
    _no_output(tmp_path, lambda out: convert_bag(bag, out),
               r"topic '/PSM1/measured_js' message 0: unknown joint names \['elbow'\]")
    bag = write_ros2(tmp_path / "bag5", _bench(), StoragePlugin.MCAP, arm_names=names[:5])
    _no_output(tmp_path, lambda out: convert_bag(bag, out), r"joints \['wrist_pitch'\] missing")


def test_unknown_columns_in_topics_and_column_maps(tmp_path):
    bag = write_ros2(tmp_path / "bag", _bench(), StoragePlugin.MCAP)
    _no_output(tmp_path, lambda out: convert_bag(bag, out, topics={"hex": "/x"}),
               r"unknown stream names in topics: \['hex'\]")
    src = tmp_path / "export.csv"
    convert_bag(bag, src)
    mapping = tmp_path / "map.json"
    mapping.write_text(json.dumps({"fx": "force_x"}))
    with pytest.raises(RecordingError, match=r"maps to unknown columns \['force_x'\]"):
        load_column_map(mapping)
    out = tmp_path / "mapped.csv"
    with pytest.raises(RecordingError, match=r"column map names columns the file lacks: \['Fx'\]"):
        convert_csv(src, out, {"Fx": "fx"})
    assert not out.exists()


def test_csv_export_with_other_column_names(tmp_path):
    bag = write_ros2(tmp_path / "bag", _bench(seed=6), StoragePlugin.MCAP)
    ours = tmp_path / "ours.csv"
    convert_bag(bag, ours)
    frame = read_recording(ours)
    theirs = {c: f"their_{c}" for c in frame.columns}
    frame.rename(columns=theirs).to_csv(tmp_path / "export.csv", index=False)
    (tmp_path / "map.json").write_text(json.dumps({v: k for k, v in theirs.items()}))
    report = convert_csv(tmp_path / "export.csv", tmp_path / "back.csv", tmp_path / "map.json")
    back = read_recording(tmp_path / "back.csv")
    assert report["rows"] == len(frame) and list(back.columns) == list(frame.columns)
    np.testing.assert_array_equal(back.to_numpy(), frame.to_numpy())

