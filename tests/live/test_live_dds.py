"""End to end over real DDS on loopback, three processes: a robot plays a recording at 1 kHz
(python -m psmforce.live.sim_robot), `psmforce serve` estimates, this test subscribes and tares.
The wrenches received equal the offline streaming estimate of the same recording to 1e-6 N,
every one arrives, and the tare removes the mean of the answers it collected."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from tests.live.test_live_replay import START_NS, checkpoint, offline
from tests.estimators.test_streaming import one_thread, recording  # noqa: F401

from psmforce.io.bags.messages import stream_columns
from psmforce.io.recording import read_recording, write_recording

pytest.importorskip("cyclonedds")
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

from psmforce.live import dds  # noqa: E402
from psmforce.live.node import STALE, TARING, output_topics  # noqa: E402

N = 1500          # 1.5 s at 1 kHz
N_TARED = 3000    # the tared stream: room for a tare asked late on a loaded machine
TARE_AT = 600     # answers received before the tare is asked for (warm-up: 150)
TARE_S = 0.05     # 50 answers


def _env():
    return dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=os.getcwd())


def _take(readers, got):
    """What the readers hold (a writer leaving gives an invalid sample: skipped)."""
    for name, reader in readers.items():
        got[name] += [m for m in reader.take(N=1000) if m.sample_info.valid_data]


@pytest.mark.slow
@pytest.mark.e2e
def test_serve_over_dds_equals_the_offline_estimate_loses_nothing_and_tares(tmp_path):
    domain_id = 100 + os.getpid() % 100
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    frame = recording(N_TARED)
    frame["time"] = np.arange(N_TARED) / 1000.0
    write_recording(frame, tmp_path / "session.csv")
    frame = read_recording(tmp_path / "session.csv", require_targets=False)  # as published
    participant = DomainParticipant(domain_id)
    topics = output_topics("PSM1")
    qos = dds.qos()
    # The test's own readers keep everything: in a long pytest process this thread can stall
    # for more than a second (1,000 messages), and a KeepLast(1000) reader would then drop the
    # oldest answers, a loss of the test's, not of the node's.
    from cyclonedds.core import Policy, Qos
    keep_all = Qos(Policy.Reliability.Reliable(max_blocking_time=0),
                   Policy.Durability.Volatile, Policy.History.KeepAll)
    readers = {name: DataReader(participant, Topic(participant, dds.dds_topic(topics[name]),
                                                   kind), qos=keep_all)
               for name, kind in (("hex10", dds.WrenchStamped), ("base", dds.WrenchStamped),
                                  ("flags", dds.UInt32))}
    tare = DataWriter(participant, Topic(participant, dds.dds_topic(topics["tare"]), dds.Empty),
                      qos=qos)
    node = subprocess.Popen(
        [sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt), "--domain-id",
         str(domain_id), "--sync-stamps", "--idle-stop", "1.5", "--tare-s", str(TARE_S),
         "--sync-wait", "1.0",  # a loaded test machine holds a resent datagram back longer
         "--input-rate", "1000",  # built before it subscribes: the tare lands mid-stream
         "--json", str(tmp_path / "report.json")], env=_env(), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    robot = None
    got = {name: [] for name in readers}
    try:
        deadline = time.monotonic() + 60
        while not all(r.get_matched_publications() for r in readers.values()):
            assert time.monotonic() < deadline and node.poll() is None, node.communicate()
            time.sleep(0.05)
        while not tare.get_matched_subscriptions():
            time.sleep(0.05)
        robot = subprocess.Popen(
            [sys.executable, "-m", "psmforce.live.sim_robot", str(tmp_path / "session.csv"),
             "--domain-id", str(domain_id), "--start-ns", str(START_NS)], env=_env(),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        tared = False
        deadline = time.monotonic() + 60
        while len(got["flags"]) < N_TARED and time.monotonic() < deadline and node.poll() is None:
            _take(readers, got)
            if not tared and len(got["hex10"]) >= TARE_AT:
                tare.write(dds.Empty())
                tared = True
            time.sleep(0.01)
        out, err = robot.communicate(timeout=30)
        assert robot.returncode == 0, err
        _, err = node.communicate(timeout=30)
        assert node.returncode == 0, err
    finally:
        for process in (robot, node):
            if process is not None and process.poll() is None:
                process.kill()
    _take(readers, got)
    report = json.loads((tmp_path / "report.json").read_text())
    outs, stamps = offline(ckpt, frame)
    received = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got["hex10"]]
    assert received == stamps.tolist(), (  # none lost, in order, each stamped with its input
        len(received), report)
    assert len(got["base"]) == len(got["flags"]) == N_TARED
    force = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z]
                      for m in got["hex10"]])
    base = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z]
                     for m in got["base"]])
    flags = np.array([m.data for m in got["flags"]])
    raw = np.stack([o.force_hex10 for o in outs])
    taring = np.flatnonzero(flags & TARING)
    n_tare = round(TARE_S * 1000)
    assert len(taring) == n_tare - 1 and taring[0] >= TARE_AT  # the last one completes it
    done = taring[-1] + 1
    offset = raw[taring[0]:done + 1].mean(axis=0)
    assert report["unpaired"] == 0, report  # every trigger met its own partners
    np.testing.assert_allclose(force[:done], raw[:done], atol=1e-6)
    np.testing.assert_allclose(force[done:], raw[done:] - offset, atol=1e-6)
    np.testing.assert_allclose(base[:done], [o.force_base for o in outs[:done]], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(base, axis=1), np.linalg.norm(force, axis=1),
                               atol=1e-9)  # the base frame is a rotation of the HEX10 frame
    assert ((flags & 0xFFFF) == [o.flags for o in outs]).all() and not (flags & STALE).any()
    assert report["received"]["hex10"] == N_TARED and report["answers_published"] == N_TARED
    assert report["decimation"] == 10 and report["received"]["tare"] == 1
    np.testing.assert_allclose(report["tare_offset_N"], offset, atol=1e-9)


@pytest.mark.slow
def test_serve_measuring_the_rate_loses_nothing(tmp_path):
    """Without --input-rate the node builds the estimator before it subscribes, measures the
    rate from the first HEX10 stamps and sets the estimator to it (issue 47, item 2: it was
    built only then, 0.6-1.1 s after the first input): every message is answered, in order."""
    import threading

    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    from psmforce.live.sim_robot import play
    from psmforce.live.serve import RATE_MESSAGES, DdsNode
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    frame = recording(N)
    frame["time"] = np.arange(N) / 1000.0
    participant = DomainParticipant(100 + (os.getpid() + 50) % 100)
    node = DdsNode(ckpt, participant, sync=True)
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
               Policy.History.KeepLast(4 * N))  # the answers come in one burst: keep them all
    readers = {"hex10": DataReader(participant, Topic(participant, dds.dds_topic(
        node.output_topics["hex10"]), dds.WrenchStamped), qos=deep)}
    robot = threading.Thread(target=play, args=(frame, participant),
                             kwargs={"start_ns": START_NS})
    robot.start()
    report = node.spin(duration_s=60, idle_stop_s=1.0)
    robot.join(30)
    got = {"hex10": []}
    for _ in range(4):  # 1000 a take
        _take(readers, got)
    assert report["received"]["hex10"] == N and report["answers_published"] == N, report
    assert report["input_rate_hz"] == pytest.approx(1000.0) and report["unpaired"] == 0
    assert RATE_MESSAGES <= 10  # the first answer waits for at most 10 ms of input at 1 kHz
    stamps = START_NS + np.arange(N) * 10**6
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got["hex10"]] \
        == stamps.tolist()


def _played_through(node, participant, frame, reader_qos) -> tuple[dict, np.ndarray]:
    """``frame`` played by the simulated robot in a thread of ``participant`` to ``node``:
    the node's report and the HEX10-frame forces a subscriber received."""
    import threading

    from psmforce.live.sim_robot import play
    reader = DataReader(participant, Topic(participant, dds.dds_topic(
        node.output_topics["hex10"]), dds.WrenchStamped), qos=reader_qos)
    robot = threading.Thread(target=play, args=(frame, participant),
                             kwargs={"start_ns": START_NS})
    robot.start()
    report = node.spin(duration_s=60, idle_stop_s=1.0)
    robot.join(30)
    got = [m for m in reader.take(N=len(frame)) if m.sample_info.valid_data]
    return report, np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z]
                             for m in got])


def _streamed(ckpt, frame, **options) -> list:
    """The estimator's own HEX10-frame forces over ``frame`` stamped as the robot stamps it."""
    from psmforce.estimators.runtime.streaming import StreamingEstimator
    from psmforce.robot import PSM
    est = StreamingEstimator.from_checkpoint(ckpt, input_rate_hz=1000.0, psm=PSM(), **options)
    stamps = START_NS + np.arange(len(frame)) * 10**6
    return [est.step(dict(row, time=s * 1e-9)).force_hex10
            for row, s in zip(frame.to_dict("records"), stamps)]


@pytest.mark.slow
def test_serve_with_the_network_after_the_answer_writes_each_answer_before_its_step(tmp_path):
    """``network_after_answer``: every network step after the first runs once the answer of
    the sample it is due on is written, and the answers equal the estimator's own stream with
    that option (issue 47, item 8: the network off the answer's path)."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    from psmforce.live.serve import DdsNode
    n = 300
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    frame = recording(n)
    frame["time"] = np.arange(n) / 1000.0
    participant = DomainParticipant(100 + (os.getpid() + 70) % 100)
    node = DdsNode(ckpt, participant, sync=True, input_rate_hz=1000.0,
                   network_after_answer=True)
    written_at_step = []
    step = node._estimator._net.step
    node._estimator._net.step = lambda x: (written_at_step.append(node.published), step(x))[1]
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
               Policy.History.KeepLast(4 * n))
    report, force = _played_through(node, participant, frame, deep)
    assert report["answers_published"] == n, report
    # the first step comes before the first answer; each later one after its sample's answer
    assert written_at_step == [0] + list(range(11, n + 1, 10))
    np.testing.assert_allclose(force, _streamed(ckpt, frame, network_after_answer=True),
                               atol=1e-6)


def test_serve_skips_and_counts_messages_that_do_not_decode(tmp_path, capsys):
    """Bytes that DDS delivers but that are not the topic's message are counted and skipped
    with one line per stream, never fatal: every good HEX10 message is answered. (Cyclone DDS
    refuses bytes cut short on both ends; a string that is not UTF-8 it passes through.)"""
    from psmforce.live import cdr
    from psmforce.live.sim_robot import Robot
    from psmforce.live.serve import DdsNode
    participant = DomainParticipant(100 + (os.getpid() + 25) % 100)
    node = DdsNode(checkpoint(tmp_path / "h.pt", rate_hz=100.0), participant,
                   input_rate_hz=1000.0)
    robot = Robot(participant)
    assert robot.wait_for_readers(30)
    names = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
    good_js = cdr.joint_state(START_NS, "", names, [0.1] * 6, [0.0] * 6, [0.0] * 6)
    for _ in range(2):
        dds.write_raw(robot.writers["js"], good_js.replace(b"yaw", b"\xff\xfe\xfd"))
    dds.write_raw(robot.writers["hex10"], cdr.wrench_stamped(START_NS, "ab", [1, 2, 3])
                  .replace(b"ab\x00", b"\xff\xfe\x00"))
    frame = recording(300)
    values = {s: frame[list(stream_columns(s))].to_numpy(np.float64) for s in robot.writers}
    for i in range(300):
        robot.publish(START_NS + (i + 1) * 10**6, {s: v[i] for s, v in values.items()})
    report = node.spin(duration_s=60, idle_stop_s=1.0)
    assert report["malformed"] == {"js": 2, "jaw": 0, "hex10": 1, "tare": 0}
    assert report["received"]["hex10"] == 300 and report["answers_published"] == 300
    err = capsys.readouterr().err.splitlines()
    assert [line.split(":")[1].strip() for line in err if line.startswith("serve:")] == [
        node.input_topics["hex10"], node.input_topics["js"]], err  # one a stream, HEX10 first


@pytest.mark.slow
@pytest.mark.e2e
def test_a_wait_for_partners_that_is_not_positive_is_refused(tmp_path):
    from psmforce.estimators.runtime.streaming import StreamingEstimator
    from psmforce.robot import PSM
    from psmforce.live.node import ForceNode
    from psmforce.live.serve import DdsNode
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    participant = DomainParticipant(100 + (os.getpid() + 75) % 100)
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="partners must be > 0 s"):
            DdsNode(ckpt, participant, sync=True, sync_wait_s=bad)   # before it subscribes
        with pytest.raises(ValueError, match="partners must be > 0 s"):
            ForceNode(StreamingEstimator.from_checkpoint(ckpt, psm=PSM()), max_wait_s=bad)
    run = subprocess.run([sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt),
                          "--sync-stamps", "--sync-wait", "0", "--duration", "1"],
                         env=_env(), capture_output=True, text=True, timeout=120)
    assert run.returncode != 0 and "partners must be > 0 s, got 0.0" in run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.slow
@pytest.mark.e2e
@pytest.mark.parametrize("signum", ["SIGINT", "SIGTERM"])
def test_a_signal_ends_serve_with_its_report_written(tmp_path, signum):
    """Issue 46, class 9: Ctrl-C on ``serve --sim`` ended in SIGABRT without its report in 2
    of 3 tries. SIGINT and SIGTERM now both stop the loop, wait for an estimator still being
    built, and write the report and --json."""
    import signal
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    for flowing in (False, True):  # while it starts, and once the robot's messages flow
        report = tmp_path / f"report_{flowing}.json"
        # as from a terminal: a suite run as a background job (``pytest &``) would hand the
        # node an ignored SIGINT, which serve rightly leaves ignored
        node = subprocess.Popen([sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt),
                                 "--sim", "--json", str(report)], env=_env(),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            assert "listening on" in node.stdout.readline()
            if flowing:  # its first progress line with answers (one a second), not a fixed 5 s
                deadline, line = time.monotonic() + 60, ""
                while "answers/s" not in line:
                    line = node.stdout.readline()
                    assert line and time.monotonic() < deadline, "no answer from serve --sim"
            else:
                time.sleep(0.5)
            node.send_signal(getattr(signal, signum))
            _, err = node.communicate(timeout=60)
        finally:
            node.kill()
        assert node.returncode == 0, err[-1000:]
        assert f"{signum}: stopping" in err and "Traceback" not in err
        received = json.loads(report.read_text())["received"]["hex10"]
        assert received > 0 or not flowing


def test_serve_refuses_a_checkpoint_before_it_subscribes(tmp_path, capsys):
    """Issue 46, class 11: a checkpoint that does not exist, or does not stream, was refused
    only once the first messages came (or never, with none)."""
    from psmforce.cli.main import main
    assert main(["serve", str(tmp_path / "missing.pt"), "--duration", "30"]) == 2
    out, err = capsys.readouterr()
    assert "missing.pt does not exist" in err and "listening" not in out


@pytest.mark.slow
def test_busy_poll_never_sleeps_and_answers_as_the_sleeping_node(tmp_path):
    """``busy_poll``: the node polls its wait set (a zero timeout, every call) and its answers
    are the estimator's own stream, every one published."""
    from psmforce.live.serve import DdsNode
    n = 200
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    frame = recording(n)
    frame["time"] = np.arange(n) / 1000.0
    participant = DomainParticipant(100 + (os.getpid() + 80) % 100)
    node = DdsNode(ckpt, participant, sync=True, input_rate_hz=1000.0, busy_poll=True)
    timeouts = []
    wait = node._waitset.wait
    node._waitset.wait = lambda timeout: (timeouts.append(timeout), wait(timeout))[1]
    report, force = _played_through(node, participant, frame, dds.qos(reader=True))
    assert report["answers_published"] == n, report
    assert timeouts and set(timeouts) == {0}
    assert len(force) == n
    np.testing.assert_allclose(force, _streamed(ckpt, frame), atol=1e-6)


def test_busy_poll_under_a_real_time_priority_is_refused_in_one_line(tmp_path, capsys,
                                                                     monkeypatch):
    from psmforce.cli.main import main
    from psmforce.live.serve import DdsNode
    assert main(["serve", str(tmp_path / "h.pt"), "--busy-poll", "--rt-priority", "10",
                 "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert "busy polling in a real-time thread (--rt-priority)" in err
    assert "Traceback" not in err
    # the library's node, in a thread already real-time: refused before it subscribes
    monkeypatch.setattr(os, "sched_getscheduler", lambda pid: os.SCHED_FIFO)
    participant = DomainParticipant(100 + (os.getpid() + 85) % 100)
    with pytest.raises(ValueError, match="busy polling in a real-time thread"):
        DdsNode(tmp_path / "h.pt", participant, busy_poll=True)


@pytest.mark.slow
@pytest.mark.e2e
def test_serve_says_which_peer_qos_cannot_match_and_which_topic_has_no_publisher(tmp_path):
    """Issue 47, item 3: a publisher whose QoS cannot match the node's readers, a subscriber
    the node's writers cannot serve, and an input topic with no publisher were never
    mentioned. Each is one line on stderr, in the report's ``warnings``, saying what to change;
    ``--best-effort`` no longer switches the writers."""
    domain = 100 + (os.getpid() + 25) % 100
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    participant = DomainParticipant(domain)
    sensor_qos = dds.qos(True)  # best effort: what a sensor-data publisher offers
    writer = DataWriter(participant, Topic(participant, dds.dds_topic("/hex10/measured_cf"),
                                           dds.WrenchStamped), qos=sensor_qos)
    reliable = DataReader(participant, Topic(participant, dds.dds_topic(
        "/PSM1/tool_force/base"), dds.WrenchStamped), qos=dds.qos(False))
    # the two nodes run at the same time (they used to run in turn): neither has a reader or a
    # writer on a topic the other serves (inputs and tare read, outputs written), so each sees
    # only the test's peers, and each still runs its whole --duration
    runs = {}
    for name, extra in (("default", []), ("best_effort_writers", ["--writer-qos",
                                                                   "best-effort"])):
        runs[name] = subprocess.Popen(
            [sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt), "--domain-id",
             str(domain), "--duration", "7", "--json", str(tmp_path / f"{name}.json"), *extra],
            env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for name, node in runs.items():
            _, err = node.communicate(timeout=120)
            assert node.returncode == 0, err[-2000:]
            runs[name] = (err, json.loads((tmp_path / f"{name}.json").read_text())["warnings"])
    finally:
        for node in runs.values():
            if isinstance(node, subprocess.Popen):
                node.kill()
    err, warnings = runs["default"]
    assert "a publisher of /hex10/measured_cf offers QoS this node's reader cannot match: " \
           "RELIABILITY" in err and "--reader-qos best-effort" in err
    assert "no publisher of /PSM1/measured_js matched in 5 s on domain" in err
    assert "subscriber" not in err  # reliable writers serve the reliable subscriber
    assert all(w in err for w in warnings) and len(warnings) == 4  # hex10 qos, js, jaw, hex10 none
    err, _ = runs["best_effort_writers"]
    assert "a subscriber of /PSM1/tool_force/base requests QoS this node's writer cannot " \
           "offer: RELIABILITY (a reliable subscriber: run with --writer-qos reliable)" in err
    del writer, reliable


@pytest.mark.slow
@pytest.mark.e2e
def test_every_endpoint_of_the_node_carries_its_ros_2_type_hash(tmp_path):
    """Issue 47, item 7: Jazzy's tools warned for every endpoint of the node, which carried no
    type hash. Read back by DDS discovery (the builtin topics, as a ROS 2 tool sees them), each
    reader and writer carries ``typehash=RIHS01_...;`` equal to rosbags' hash of its type."""
    from cyclonedds.builtin import (BuiltinDataReader, BuiltinTopicDcpsPublication,
                                    BuiltinTopicDcpsSubscription)
    from cyclonedds.core import Policy

    from psmforce.io.bags import ROS2_TYPESTORE
    from psmforce.live.serve import DdsNode
    domain = 100 + (os.getpid() + 35) % 100
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    node = DdsNode(ckpt, DomainParticipant(domain), input_rate_hz=100.0)
    tool = DomainParticipant(domain)
    found: dict[str, bytes] = {}
    deadline = time.monotonic() + 10
    readers = [BuiltinDataReader(tool, BuiltinTopicDcpsPublication),
               BuiltinDataReader(tool, BuiltinTopicDcpsSubscription)]
    wanted = {dds.dds_topic(t) for t in [*node.input_topics.values(),
                                         *node.output_topics.values()]}
    while time.monotonic() < deadline and not wanted <= set(found):
        for reader in readers:
            for sample in reader.take(N=100):
                data = sample.qos[Policy.Userdata]
                found[sample.topic_name] = data.data if data is not None else b""
        time.sleep(0.1)
    assert wanted <= set(found), sorted(wanted - set(found))
    by_topic = {dds.dds_topic(node.input_topics["js"]): "sensor_msgs/msg/JointState",
                dds.dds_topic(node.input_topics["hex10"]): "geometry_msgs/msg/WrenchStamped",
                dds.dds_topic(node.output_topics["flags"]): "std_msgs/msg/UInt32",
                dds.dds_topic(node.output_topics["std"]): "geometry_msgs/msg/Vector3Stamped",
                dds.dds_topic(node.output_topics["tare"]): "std_msgs/msg/Empty"}
    for topic, ros_type in by_topic.items():
        assert found[topic] == f"typehash={ROS2_TYPESTORE.hash_rihs01(ros_type)};".encode()


@pytest.mark.slow
def test_a_repeated_stamp_among_the_first_messages_over_dds_is_flagged_not_fatal(tmp_path):
    """Issue 47, item 4, over real DDS: without --input-rate the node measures the rate from
    the first HEX10 stamps; one repeated stamp among them (the robot sends sample 3 with
    sample 2's stamp, on every stream) is flagged TIME_BACKWARDS, the rate is still measured
    right, and every later message is answered."""
    import threading

    from psmforce.estimators.runtime.streaming import Flags
    from psmforce.live.serve import RATE_MESSAGES, DdsNode
    from psmforce.live.sim_robot import play
    n = 1000
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    frame = recording(n)
    frame["time"] = np.arange(n) / 1000.0
    frame.loc[3, "time"] = frame.loc[2, "time"]
    assert 3 < RATE_MESSAGES
    participant = DomainParticipant(100 + (os.getpid() + 55) % 100)
    node = DdsNode(ckpt, participant, sync=True)
    robot = threading.Thread(target=play, args=(frame, participant),
                             kwargs={"start_ns": START_NS})
    robot.start()
    report = node.spin(duration_s=60, idle_stop_s=1.0)
    robot.join(30)
    assert report["received"]["hex10"] == n, report
    assert report["input_rate_hz"] == pytest.approx(1000.0), report
    assert report["flag_counts"].get(Flags.TIME_BACKWARDS.bit_length() - 1, 0) >= 1, report
    assert report["answers_published"] >= n - 1, report


@pytest.mark.slow
@pytest.mark.e2e
def test_a_10x_burst_loses_nothing(tmp_path):
    """Issue 47, item 1: a 10x burst lost a third of its messages in the node's keep-last
    readers while a plain subscriber lost none. 5000 samples of a 1 kHz stream published at 10
    times its rate (0.5 s; pre-encoded, so the writes set the pace) to ``serve`` in another
    process: every message of every stream is received and every HEX10 message answered. The
    rate reached is checked loosely (a shared CI machine); benchmarks/live.py records it."""
    from psmforce.live.sim_robot import play
    domain = 100 + (os.getpid() + 45) % 100
    n = 5000
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    report = tmp_path / "report.json"
    node = subprocess.Popen([sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt),
                             "--domain-id", str(domain), "--input-rate", "1000",
                             "--idle-stop", "3", "--duration", "120", "--json", str(report)],
                            env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        assert "listening on" in node.stdout.readline()
        frame = recording(n)
        frame["time"] = np.arange(n) / 1000.0
        sent = play(frame, DomainParticipant(domain), speed=10.0, start_ns=START_NS)["sent_ns"]
        rate = (n - 1) / ((sent[-1] - sent[0]) * 1e-9)
        _, err = node.communicate(timeout=120)
    finally:
        node.kill()
    assert node.returncode == 0, err[-2000:]
    result = json.loads(report.read_text())
    # a burst of at least twice the stream's rate, paced at 10x: a shared machine running
    # other tests beside this one does not always reach 10x (benchmarks/live.py records the
    # rate a quiet one reaches)
    assert 2000 < rate < 10_500, rate
    assert result["received"] == {"js": n, "jaw": n, "hex10": n, "tare": 0}, (rate, result)
    assert result["answers_published"] == n
    own = result["residence_ms"]  # every answer's residence, taken to written (serve, Residence)
    assert own["n"] == n and 0 < own["median_ms"] <= own["p99_ms"] <= own["max_ms"], own
    writes = result["residence_writes_ms"]  # a share of the same answers' residences
    assert writes["n"] == n and 0 < writes["median_ms"] <= own["median_ms"], (writes, own)
    assert writes["max_ms"] <= own["max_ms"], (writes, own)


@pytest.mark.slow
@pytest.mark.e2e
def test_a_node_with_discovery_off_sees_no_other_process_and_localhost_does(tmp_path):
    """Between processes on one machine: LOCALHOST on both sides finds the robot; OFF finds
    nothing, as a ROS 2 node with that range would. Both nodes listen on the one domain at the
    same time, the OFF one from before the robot starts until after it has finished: the robot's
    messages are on the domain, and answered by the LOCALHOST node, all the while the OFF node
    listens (each node used to run a fixed 10 s in turn: the same check, run once, in parallel)."""
    import signal
    # A node with discovery OFF listens on ephemeral ports (Cyclone's ParticipantIndex none); the
    # LOCALHOST robot sends its announcements to the well-known unicast ports of participant
    # indices 0..120 on its domain (7400 + 250 * domain + 10 + 2 * index). On a domain of 100 or
    # more those ports lie inside Linux's ephemeral range (32768 and up), so an OFF node whose
    # port happened to be one of them was found by the robot: a chance collision of the test, not
    # discovery (CI saw it once). Domains 50-99 keep every announced port below that range.
    domain = 50 + (os.getpid() + 55) % 50
    with open("/proc/sys/net/ipv4/ip_local_port_range") as ports:
        low_port = int(ports.read().split()[0])
    if 7400 + 250 * domain + 10 + 2 * 120 >= low_port:
        pytest.skip(f"this machine's ephemeral ports start at {low_port}, below domain {domain}'s "
                    "well-known ports: the OFF node could be found by chance")
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    rec = tmp_path / "rec.csv"
    frame = recording(300)
    frame["time"] = np.arange(300) / 100.0
    write_recording(frame, rec)
    nodes, robot = {}, None
    try:
        for node_range, ending in (("OFF", []), ("LOCALHOST", ["--idle-stop", "1"])):
            # OFF is stopped by a signal once the robot is done (serve then writes its report);
            # LOCALHOST stops 1 s after its last message; --duration 60 is only a ceiling
            nodes[node_range] = subprocess.Popen(
                [sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt), "--domain-id",
                 str(domain), "--duration", "60", *ending, "--quiet", "--json",
                 str(tmp_path / f"{node_range}.json")],
                env=dict(_env(), ROS_AUTOMATIC_DISCOVERY_RANGE=node_range),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for node in nodes.values():  # subscribed, both: the robot may start
            assert "listening on" in node.stdout.readline()
        robot = subprocess.Popen([sys.executable, "-m", "psmforce.live.sim_robot", str(rec),
                                  "--domain-id", str(domain)],  # plays it once: 3 s
                                 env=dict(_env(), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"),
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _, err = robot.communicate(timeout=60)
        assert robot.returncode == 0, err[-2000:]  # it found a node (LOCALHOST) and played
        _, err = nodes["LOCALHOST"].communicate(timeout=60)
        assert nodes["LOCALHOST"].returncode == 0, err[-2000:]
        nodes["OFF"].send_signal(signal.SIGTERM)
        _, err = nodes["OFF"].communicate(timeout=60)
        assert nodes["OFF"].returncode == 0, err[-2000:]
    finally:
        for process in (robot, *nodes.values()):
            if process is not None:
                process.kill()
    received = {name: json.loads((tmp_path / f"{name}.json").read_text())["received"]["hex10"]
                for name in nodes}
    assert received["LOCALHOST"] > 0 and received["OFF"] == 0, received


@pytest.mark.slow
@pytest.mark.e2e
def test_serve_under_a_real_time_priority_answers_and_reports_it(tmp_path):
    allowed = subprocess.run([sys.executable, "-c", "from psmforce.live.scheduling import "
                              "run_realtime; run_realtime(10)"], env=_env(),
                             capture_output=True, text=True, timeout=60).returncode == 0
    if not allowed:
        pytest.skip("this system refuses SCHED_FIFO")
    ckpt = checkpoint(tmp_path / "h.pt", rate_hz=100.0)
    report = tmp_path / "report.json"
    done = subprocess.run([sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt), "--sim",
                           "--duration", "3", "--quiet", "--rt-priority", "10", "--json",
                           str(report)], env=_env(), capture_output=True, text=True,
                          timeout=180)
    assert done.returncode == 0, done.stderr[-1000:]
    result = json.loads(report.read_text())
    assert result["scheduling"] == "SCHED_FIFO 10" and result["received"]["hex10"] > 0
