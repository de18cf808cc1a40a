"""``psmforce replay``: a bag through the node's code path; the MCAP's wrenches equal the offline
streaming estimate; tare; the shared message decoding; the live Foxglove view."""

from __future__ import annotations

import json
import socket
import threading
import time

import numpy as np
import pytest
from tests.estimators.test_streaming import (INSERTION, model_and_scalers, one_thread, recording)  # noqa: F401

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.data.hybrid_inputs import hybrid_columns, prior_to_json
from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
from psmforce.robot import PSM
from psmforce.io.bags import ROS2_TYPESTORE, MessageError, sample_from_messages
from psmforce.io.bags.messages import SampleArray
from psmforce.io.bags.writing import write_bag
from psmforce.identification.prior import InternalForcePrior

pytest.importorskip("mcap")
from mcap.reader import make_reader  # noqa: E402

START_NS = 1_700_000_000 * 10**9
CONFIG = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}
TOPIC = "/PSM1/tool_force/hex10"


def checkpoint(path, rate_hz=100.0):
    """A small hybrid with the identification prior (physical default parameters)."""
    features, base = hybrid_columns(True)
    model, xs, ys = model_and_scalers(len(features))
    return ck.TrainedModel("hybrid", CONFIG, features, xs, ys, base, model=model,
                           derivation="prior", sample_rate_hz=rate_hz,
                           prior_json=prior_to_json(InternalForcePrior(converged=True,
                                                                       insertion=INSERTION))
                           ).save(path)


def session(tmp_path, n=600, rate_hz=1000.0):
    """A recording at ``rate_hz`` and the ROS 2 bag of it, as the bench records one."""
    frame = recording(n)
    frame["time"] = np.arange(n) / rate_hz
    bag = tmp_path / "session"
    write_bag(frame, bag, start_ns=START_NS)
    return frame, bag


def offline(ckpt, frame, rate_hz=1000.0):
    """The streaming estimator stepped over the recording, times as the node gives them."""
    est = StreamingEstimator.from_checkpoint(ckpt, input_rate_hz=rate_hz, psm=PSM())
    stamps = START_NS + np.rint(frame["time"].to_numpy() * 1e9).astype(np.int64)
    outs = [est.step(dict(row, time=s * 1e-9), base_frame=True)
            for row, s in zip(frame.to_dict("records"), stamps)]
    return outs, stamps


def read_mcap(path, topic):
    """(log ns, message) of ``topic`` in the MCAP, decoded with rosbags."""
    with open(path, "rb") as f:
        return [(m.log_time, ROS2_TYPESTORE.deserialize_cdr(m.data, s.name))
                for s, c, m in make_reader(f).iter_messages(topics=[topic])]


def test_replay_writes_the_offline_estimate_in_both_frames(tmp_path):
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt")
    frame, bag = session(tmp_path)
    report = replay(bag, ckpt, tmp_path / "out.mcap")
    assert report["input_rate_hz"] == pytest.approx(1000.0) and report["decimation"] == 10
    outs, stamps = offline(ckpt, frame)
    hex10 = read_mcap(tmp_path / "out.mcap", TOPIC)
    base = read_mcap(tmp_path / "out.mcap", "/PSM1/tool_force/base")
    flags = read_mcap(tmp_path / "out.mcap", "/PSM1/tool_force/flags")
    assert len(hex10) == len(base) == len(flags) == len(frame) == report["answers"]
    got = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z] for _, m in hex10])
    np.testing.assert_allclose(got, [o.force_hex10 for o in outs], atol=1e-9)
    got = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z] for _, m in base])
    np.testing.assert_allclose(got, [o.force_base for o in outs], atol=1e-9)
    assert [m.data for _, m in flags] == [o.flags for o in outs]
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in hex10] \
        == stamps.tolist()  # each answer carries the stamp of the input it answers
    assert {m.header.frame_id for _, m in hex10} == {"hex10"}
    assert {m.header.frame_id for _, m in base} == {"PSM1_base"}
    assert report["topics"]["/hex10/measured_cf"] == len(frame)  # the inputs, beside
    layout = json.loads((tmp_path / "out.layout.json").read_text())
    assert layout["configById"]["Plot!force_x"]["paths"][0]["value"] == TOPIC + ".wrench.force.x"


def test_replay_tare_on_start_removes_the_mean_of_the_first_settled_answers(tmp_path):
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    frame, bag = session(tmp_path, n=300)
    report = replay(bag, ckpt, tmp_path / "out.mcap", tare_on_start=True)
    outs, _ = offline(ckpt, frame)
    raw = np.stack([o.force_hex10 for o in outs])
    settled = [k for k, o in enumerate(outs) if not o.flags & (Flags.WARMING_UP | Flags.HELD)]
    assert len(settled) < 500  # a short session: the tare never completes, nothing subtracted
    assert report["tare_offset_N"] == [0.0, 0.0, 0.0]
    (tmp_path / "long").mkdir()
    frame, bag = session(tmp_path / "long", n=800)
    report = replay(bag, ckpt, tmp_path / "long.mcap", tare_on_start=True, tare_s=0.2)
    outs, _ = offline(ckpt, frame)
    raw = np.stack([o.force_hex10 for o in outs])
    settled = [k for k, o in enumerate(outs) if not o.flags & (Flags.WARMING_UP | Flags.HELD)]
    offset = raw[settled[:200]].mean(axis=0)
    np.testing.assert_allclose(report["tare_offset_N"], offset, atol=1e-9)
    got = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z]
                    for _, m in read_mcap(tmp_path / "long.mcap", TOPIC)])
    after = settled[199]  # the answer that completes the tare is the first tared
    np.testing.assert_allclose(got[after:], raw[after:] - offset, atol=1e-9)
    np.testing.assert_allclose(got[:after], raw[:after], atol=1e-9)
    taring = [m.data & (1 << 16) for _, m in read_mcap(tmp_path / "long.mcap",
                                                         "/PSM1/tool_force/flags")]
    assert all(taring[:after]) and not any(taring[after:])


def test_replay_refuses_a_stream_the_model_cannot_serve_and_writes_nothing(tmp_path):
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    _, bag = session(tmp_path, n=100, rate_hz=150.0)
    with pytest.raises(ValueError, match="150 Hz stream cannot feed a model trained at 100 Hz"):
        replay(bag, ckpt, tmp_path / "out.mcap")
    assert not list(tmp_path.glob("out*"))


def test_replay_never_replaces_a_layout_it_was_not_asked_for(tmp_path, capsys):
    """Issue 46, class 2: ``replay --out run.mcap`` silently replaced an existing
    ``run.layout.json``, and ``--json run.layout.json`` clobbered the layout it writes."""
    from psmforce.cli.main import main
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    _, bag = session(tmp_path, n=100, rate_hz=100.0)
    theirs = tmp_path / "out.layout.json"
    theirs.write_text("the user's layout")
    with pytest.raises(ValueError, match="writes .*out.layout.json beside it, and a file is there"):
        replay(bag, ckpt, tmp_path / "out.mcap")
    assert main(["replay", str(bag), str(ckpt), "--out", str(tmp_path / "out.mcap")]) == 2
    assert "a file is there already" in capsys.readouterr().err
    assert theirs.read_text() == "the user's layout" and not (tmp_path / "out.mcap").exists()
    assert main(["replay", str(bag), str(ckpt), "--out", str(tmp_path / "new.mcap"), "--json",
                 str(tmp_path / "new.layout.json")]) == 2
    assert "--json" in capsys.readouterr().err and not (tmp_path / "new.mcap").exists()


def _messages():
    types = ROS2_TYPESTORE.types
    header = types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=12, nanosec=500_000_000), frame_id="")
    joint_state = types["sensor_msgs/msg/JointState"]
    vector, wrench = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Wrench"]
    names = ["outer_roll", "outer_yaw", "jaw", "outer_pitch", "outer_wrist_yaw",
             "outer_insertion", "outer_wrist_pitch"]
    values = np.arange(7, dtype=float)
    js = joint_state(header=header, name=names, position=values, velocity=values + 10,
                     effort=values + 20)
    jaw = joint_state(header=header, name=["jaw"], position=np.array([0.3]),
                      velocity=np.array([0.1]), effort=np.array([0.05]))
    hex10 = types["geometry_msgs/msg/WrenchStamped"](header=header, wrench=wrench(
        force=vector(x=1.0, y=2.0, z=3.0), torque=vector(x=0.1, y=0.2, z=0.3)))
    return js, jaw, hex10


def test_sample_from_messages_matches_joints_by_name():
    js, jaw, hex10 = _messages()
    sample = sample_from_messages(js, jaw, hex10)
    assert sample["time"] == 12.5 and sample["fz"] == 3.0 and sample["tz"] == 0.3
    assert sample["roll_position"] == 0.0 and sample["yaw_velocity"] == 11.0
    assert sample["insertion_effort"] == 25.0 and sample["jaw_position"] == 0.3
    assert len(sample) == 28 and sample_from_messages(js, jaw, hex10, time_s=1.0)["time"] == 1.0
    js.name[0] = "elbow"
    with pytest.raises(MessageError, match="unknown joint names \\['elbow'\\]"):
        sample_from_messages(js, jaw, hex10)


def test_the_sample_array_holds_the_sample_mappings_values_in_the_estimators_order(tmp_path):
    js, jaw, hex10 = _messages()
    est = StreamingEstimator.from_checkpoint(checkpoint(tmp_path / "h.pt"), psm=PSM())
    sample = sample_from_messages(js, jaw, hex10)
    assert SampleArray(est.columns)(js, jaw, hex10).tolist() == [sample[c] for c in est.columns]
    with pytest.raises(MessageError, match="\\['ati_raw_fx'\\] are not in"):
        SampleArray(["fx", "ati_raw_fx"])
    js.name[0] = "elbow"
    with pytest.raises(MessageError, match="unknown joint names"):
        SampleArray(est.columns)(js, jaw, hex10)


def test_the_nodes_status_bytes_are_the_general_encoders(tmp_path):
    """The node encodes ``status`` once per flags value and patches the stamp in: the bytes
    must be those of cdr.diagnostic_array for any flags and any stamp's length."""
    from psmforce.live import cdr
    from psmforce.live.node import STALE, TARING, ForceNode, status_of
    est = StreamingEstimator.from_checkpoint(checkpoint(tmp_path / "h.pt"), psm=PSM())
    node = ForceNode(est, arm="PSM2")
    for flags in (0, int(Flags.WARMING_UP), int(Flags.HELD | Flags.GAP), STALE | TARING):
        for stamp in (0, 7, 999_999_999, START_NS + 123_456_789, (2**31 - 1) * 10**9 + 10**9 - 1):
            level, message = status_of(flags)
            want = cdr.diagnostic_array(stamp, "hex10", [(
                level, "psmforce/PSM2/tool_force", message, "PSM2",
                [("flags", str(flags)), ("stamp_ns", str(stamp))])])
            assert node._status(stamp, flags) == want, (flags, stamp)
            assert isinstance(node._status(stamp, flags), bytes)


def node_messages(frame, k, names=None, short=False, arm_lag_ns=0):
    """The arm, jaw and HEX10 messages of row ``k`` (1 kHz stamps), the arm's and jaw's stamped
    ``arm_lag_ns`` behind the HEX10's (another clock)."""
    types = ROS2_TYPESTORE.types

    def header(lag_ns):
        t = 100 * 10**9 + k * 1_000_000 - lag_ns
        return types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](
            sec=t // 10**9, nanosec=t % 10**9), frame_id="")

    row = frame.iloc[k]
    joints = ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"]
    arrays = [np.array([row[f"{j}_{q}"] for j in joints]) for q in
              ("position", "velocity", "effort")]
    if short:
        arrays[0] = arrays[0][:5]
    js = types["sensor_msgs/msg/JointState"](header=header(arm_lag_ns), name=names or joints,
                                              position=arrays[0], velocity=arrays[1],
                                              effort=arrays[2])
    jaw = types["sensor_msgs/msg/JointState"](
        header=header(arm_lag_ns), name=["jaw"], position=np.array([row["jaw_position"]]),
        velocity=np.array([row["jaw_velocity"]]), effort=np.array([row["jaw_effort"]]))
    vector = types["geometry_msgs/msg/Vector3"]
    hex10 = types["geometry_msgs/msg/WrenchStamped"](
        header=header(0), wrench=types["geometry_msgs/msg/Wrench"](
            force=vector(x=row["fx"], y=row["fy"], z=row["fz"]),
            torque=vector(x=row["tx"], y=row["ty"], z=row["tz"])))
    return js, jaw, hex10


def test_node_flags_a_message_that_does_not_decode_and_goes_on(tmp_path):
    """A JointState with an unknown joint name, or arrays shorter than its names, is answered
    INVALID_INPUT | HELD with the last estimate; the next good message goes on."""
    from psmforce.live.node import ForceNode
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    node = ForceNode(StreamingEstimator.from_checkpoint(ckpt, psm=PSM()))
    frame = recording(40)

    def answer(js, jaw, hex10):
        node.update("js", js)
        node.update("jaw", jaw)
        (out,) = node.update("hex10", hex10)
        return out

    good = [answer(*node_messages(frame, k)) for k in range(20)]
    assert not any(a.flags & Flags.INVALID_INPUT for a in good)
    for k, bad in ((20, {"names": ["elbow", "pitch", "insertion", "roll", "wrist_pitch",
                                   "wrist_yaw"]}), (21, {"short": True})):
        out = answer(*node_messages(frame, k, **bad))
        assert out.flags & Flags.INVALID_INPUT and out.flags & Flags.HELD
        np.testing.assert_array_equal(out.force_hex10, good[-1].force_hex10)
    after = answer(*node_messages(frame, 22))
    assert not after.flags & (Flags.INVALID_INPUT | Flags.HELD) and node.answers == 23


def test_stale_is_judged_on_the_order_received_not_on_stamps_of_two_clocks(tmp_path):
    """Issue 47, item 5: an arm clock 50 ms behind the HEX10's flagged every answer STALE
    while nothing stalled. Received in turn, nothing is stale whatever the stamps; an arm that
    stops delivering is stale once more than 10 HEX10 messages came without it."""
    from psmforce.live.node import STALE, ForceNode
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    node = ForceNode(StreamingEstimator.from_checkpoint(ckpt, psm=PSM()))
    frame = recording(60)
    flags = []
    for k in range(60):
        js, jaw, hex10 = node_messages(frame, k, arm_lag_ns=50_000_000)
        if k < 30:  # the arm and the jaw stop after 30 messages
            node.update("js", js)
            node.update("jaw", jaw)
        (out,) = node.update("hex10", hex10)
        flags.append(bool(out.flags & STALE))
    assert flags[:30] == [False] * 30  # 50 ms apart in stamps, never stale
    assert flags[30:39] == [False] * 9 and flags[39:] == [True] * 21  # 10 without, then stale


def _free_port():
    """A TCP port no one listens on now (the OS's choice: never shared with a run beside)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.slow
def test_view_serves_the_estimate_channel_to_a_websocket_client(tmp_path):
    """The client connects whenever the player gets there (any load): the replay waits for its
    subscription to the estimate, so it receives the estimates from the first answer on."""
    pytest.importorskip("foxglove")
    websocket = pytest.importorskip("websocket")
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    _, bag = session(tmp_path, n=3000)  # 3 s in real time
    port = _free_port()
    result, failed = {}, []

    def play():
        try:
            result.update(replay(bag, ckpt, tmp_path / "out.mcap", realtime=True,
                                 view_port=port, view_wait_s=120.0, view_hold_s=1.0))
        except BaseException as err:  # re-raised below, in the test's thread
            failed.append(err)

    player = threading.Thread(target=play)
    player.start()
    ws, channel, payloads = None, None, []
    try:
        deadline = time.monotonic() + 120
        while ws is None and player.is_alive() and time.monotonic() < deadline:
            try:
                ws = websocket.create_connection(f"ws://127.0.0.1:{port}", timeout=5,
                                                 subprotocols=["foxglove.sdk.v1"])
            except OSError:
                time.sleep(0.05)
        assert ws is not None, f"no server on port {port}: {failed}"
        while time.monotonic() < deadline and len(payloads) < 3:
            try:
                opcode, data = ws.recv_data()
            except websocket.WebSocketTimeoutException:
                continue  # a starved machine: the deadline decides
            if opcode == 1:
                message = json.loads(data)
                if message.get("op") == "advertise" and channel is None:
                    for c in message["channels"]:
                        if c["topic"] == TOPIC:
                            channel = c
                            assert c["encoding"] == "cdr" and c["schemaEncoding"] == "ros2msg"
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": 7, "channelId": c["id"]}]}))
            elif opcode == 2 and data[0] == 1:  # message data: op, subscription id, time, CDR
                assert int.from_bytes(data[1:5], "little") == 7
                payloads.append(ROS2_TYPESTORE.deserialize_cdr(
                    data[13:], "geometry_msgs/msg/WrenchStamped"))
    finally:
        if ws is not None:
            ws.close()
        player.join(120)
    assert not failed, failed
    assert channel is not None and len(payloads) >= 3
    assert all(np.isfinite(m.wrench.force.x) and m.header.frame_id == "hex10" for m in payloads)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in payloads]
    assert stamps == [START_NS + k * 10**6 for k in range(len(payloads))]  # from the first on
    assert result["answers"] == 3000 and result["viewer_before_play"] is True


def test_serve_never_writes_its_report_over_the_recording_it_publishes(tmp_path, capsys):
    """Issue 46, class 2: ``serve --sim --sim-recording rec.csv --json rec.csv`` overwrote the
    recording; every path a command reads is an input to the guard."""
    from psmforce.cli.main import main
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    rec = tmp_path / "rec.csv"
    rec.write_text("the user's recording")
    assert main(["serve", str(ckpt), "--sim", "--sim-recording", str(rec), "--json",
                 str(rec)]) == 2
    err = capsys.readouterr().err
    assert "--json" in err and "input" in err and rec.read_text() == "the user's recording"


def test_an_input_rate_the_stamps_contradict_is_refused(tmp_path):
    """Issue 46, class 4: ``replay --input-rate 1000`` was accepted against 100 Hz stamps."""
    from psmforce.io.bags import BagError
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    _, bag = session(tmp_path, n=100, rate_hz=100.0)
    with pytest.raises(BagError, match="--input-rate 1000 Hz, but the HEX10 stamps come at 100"):
        replay(bag, ckpt, tmp_path / "out.mcap", input_rate_hz=1000.0)
    assert not list(tmp_path.glob("out*"))


@pytest.mark.parametrize("topic", ["/hex10/measured_cf", "/PSM1/measured_js"])
def test_a_message_that_does_not_decode_is_skipped_and_counted(tmp_path, topic):
    """Issue 46, class 9: one corrupt record in a bag made replay exit 3. It is skipped, not
    copied, and counted; every other message is answered as in the clean bag."""
    from psmforce.live.replay import replay
    from tests.robustness.cases.live import corrupt_bag
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    _, bag = session(tmp_path, n=300)
    assert corrupt_bag(bag, tmp_path / "corrupt", topic, lambda raw: raw[:10],
                       lambda k: k in (150, 151)) == 2
    clean = replay(bag, ckpt, tmp_path / "clean.mcap")
    report = replay(tmp_path / "corrupt", ckpt, tmp_path / "out.mcap")
    assert report["malformed"] == {topic: 2} and clean["malformed"] == {}
    trigger = topic == "/hex10/measured_cf"
    assert report["answers"] == clean["answers"] - 2 * trigger
    assert report["inputs_copied"] == clean["inputs_copied"] - 2
    assert len(read_mcap(tmp_path / "out.mcap", TOPIC)) == report["answers"]


def test_a_repeated_stamp_among_the_first_messages_is_flagged_not_fatal(tmp_path):
    """Issue 47, item 4: the rate is measured past a bad stamp; the message is answered
    flagged TIME_BACKWARDS and the stream goes on."""
    from psmforce.live.replay import replay
    from tests.robustness.cases.live import corrupt_bag
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    _, bag = session(tmp_path, n=300)
    sec, nanosec = divmod(START_NS + 4 * 10**6, 10**9)
    corrupt_bag(bag, tmp_path / "repeated", "/hex10/measured_cf",
                lambda raw: raw[:4] + sec.to_bytes(4, "little") + nanosec.to_bytes(4, "little")
                + raw[12:], lambda k: k == 5)
    report = replay(tmp_path / "repeated", ckpt, tmp_path / "out.mcap")
    assert report["input_rate_hz"] == pytest.approx(1000.0) and report["answers"] == 300
    assert report["flag_counts"].get(Flags.TIME_BACKWARDS.bit_length() - 1) == 1


def test_status_carries_each_answers_flags_under_its_stamp(tmp_path):
    """Issue 47, item 6: ``flags`` is a bare UInt32, so a subscriber that misses one cannot
    tell which estimate it belongs to. ``status`` (diagnostic_msgs/DiagnosticArray) carries the
    same bits under the answered stamp, their names and a level."""
    from psmforce.live.node import status_of
    from psmforce.live.replay import replay
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=1000.0)
    _, bag = session(tmp_path, n=300)
    replay(bag, ckpt, tmp_path / "out.mcap", tare_on_start=True)
    hex10 = read_mcap(tmp_path / "out.mcap", TOPIC)
    flags = read_mcap(tmp_path / "out.mcap", "/PSM1/tool_force/flags")
    status = read_mcap(tmp_path / "out.mcap", "/PSM1/tool_force/status")
    assert len(status) == len(hex10) == len(flags) == 300
    levels = set()
    for (_, estimate), (_, bits), (_, array) in zip(hex10, flags, status):
        (entry,) = array.status
        values = {kv.key: kv.value for kv in entry.values}
        assert array.header.stamp == estimate.header.stamp
        assert int(values["flags"]) == bits.data
        assert int(values["stamp_ns"]) == estimate.header.stamp.sec * 10**9 \
            + estimate.header.stamp.nanosec
        assert (entry.level, entry.message) == status_of(bits.data)
        assert entry.name == "psmforce/PSM1/tool_force" and entry.hardware_id == "PSM1"
        levels.add(entry.level)
    assert 1 in levels and 2 not in levels  # warming up, taring: qualified, never unusable
    assert status_of(Flags.WARMING_UP | Flags.HELD) == (2, "WARMING_UP|HELD")


def test_a_viewer_that_disconnects_leaves_no_callback_error(capfd, caplog):
    """Issue 47, item 8: a Foxglove viewer disconnecting printed ``Callback failed:
    AttributeError: ... 'on_unsubscribe'`` for every channel it had subscribed to."""
    import json as json_

    import websocket

    from psmforce.live.view import LiveView
    topic = "/PSM1/tool_force/hex10"
    view = LiveView(0, channels={topic: "geometry_msgs/msg/WrenchStamped"})
    try:
        ws = websocket.create_connection(f"ws://127.0.0.1:{view.port}", timeout=5,
                                         subprotocols=["foxglove.sdk.v1"])
        advertised = None
        while advertised is None:
            message = ws.recv()
            if isinstance(message, str) and json_.loads(message).get("op") == "advertise":
                advertised = json_.loads(message)["channels"]
        ws.send(json_.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": advertised[0]["id"]}]}))
        assert view.wait_for_subscriber(topic, 5)
        ws.close()
        time.sleep(0.5)  # the server notices the disconnect and unsubscribes the client
    finally:
        view.close()
    printed = capfd.readouterr().err + "".join(r.getMessage() for r in caplog.records)
    assert "Callback failed" not in printed
