"""The live node's figures: per-message time, end-to-end latency over real DDS, replay speed.

    python benchmarks/live.py [--checkpoint HYBRID.pt] [--seconds 60] [--json OUT.json]

Needs the extra ``psmforce[ros]`` (cyclonedds, mcap). One thread for torch, BLAS and OpenMP (set
before they load), in every process. ``--checkpoint``: a streamable hybrid (default: one trained
here for 2 epochs on a 1 %-scale simulated bench, the default architecture at the bench's 100 Hz;
the figures below do not depend on how well it is trained). The input is a simulated palpation
session put on a 1 kHz clock (:func:`psmforce.live.sim_robot.bench_recording`): the model runs at
100 Hz, every 10th message (decimation 10, :mod:`psmforce.estimators.data.rates`). Prints and writes
(JSON):

* ``decode``: the time to decode one sample's three messages (arm and jaw JointState, HEX10
  WrenchStamped) from the CDR bytes the robot writes, by :mod:`psmforce.live.cdr` (what
  ``serve`` uses) and by ``cyclonedds``' Python classes, median / p99 in ms;
* ``node``: the time one HEX10 message takes in :class:`psmforce.live.node.ForceNode`, given the
  messages as ``serve`` decodes them (``update``: read the three streams' latest messages, one
  estimator step in the base and HEX10 frames, tare; then ``encode``: the CDR bytes of every
  output), median / p99 / max in ms,
  wall clock and the thread's CPU time, after 500 warm-up messages; split into the messages on
  which the network steps and the others (physics, anti-alias filter and post-filter only), and
  compared with the 1 ms period of a 1 kHz loop. Every answer's flags are checked free of
  GAP / RESET / INVALID_INPUT, so the split is the estimator's own (network on every 10th);
* ``dds``: three processes on loopback as on the robot: the simulated robot
  (``python -m psmforce.live.sim_robot --duration S``: arm and jaw JointState and HEX10
  WrenchStamped at 1 kHz), ``psmforce serve`` (``--input-rate 1000 --sync-stamps``) and this
  process subscribing to ``/PSM1/tool_force/hex10``: HEX10 messages sent, answers received,
  lost fraction, end-to-end latency (from the robot's write of a HEX10 message to this
  process taking the answer stamped with it, decoded as ``serve`` decodes; one clock,
  ``time.time_ns``) p50 / p99 / max in ms; beside it, taken in the same loop, the robot's HEX10
  messages themselves (``transport_latency``: the same machine's DDS and process wake-ups without
  the node, the floor under the end-to-end figure) in
  ms, and the node's CPU use (user + system time of its process over the playback / the
  playback's wall time; 1.0 = one core);
  ``node_added_latency``: per message, the answer's arrival minus the robot's own message's
  arrival in this process (the node's share of the latency, transport excluded);
  ``node_lost``: HEX10 messages the node never received; ``first_answer_ms``: from the robot's
  first HEX10 write to the first answer taken here; ``node_residence``: the node's own report of
  its share, per answer from taking its HEX10 message off the reader to writing the last output
  (:mod:`psmforce.live.serve`, Residence; the node's clock, no transport in it), against the
  goal of :data:`RESIDENCE_GOAL_P99_MS` at p99; ``node_residence_writes``: the share of those
  residences spent in the four DDS writes;
* ``dds_busy_core``: the same for a third of the time while another process keeps one core
  busy;
* ``node_network_after_answer``, ``dds_network_after_answer``,
  ``dds_busy_core_network_after_answer``: ``node``, ``dds`` and ``dds_busy_core`` again with the
  network after the answer (``serve --network after-answer``; the estimator's
  ``network_after_answer``): the network step of the sample it is due on runs once that answer
  is written (its time in ``after_the_answer``), outside the answer's residence;
  ``network_after_answer_accuracy``: what it costs the estimate, the shipped bench model over the
  session (NRMSE per axis before and after the answer, and the two estimates' difference, N);
* ``dds_realtime``, ``dds_realtime_network_after_answer``, ``dds_busy_core_realtime``,
  ``dds_busy_core_realtime_network_after_answer``: ``dds`` and ``dds_busy_core`` again, both
  orders, with the node under SCHED_FIFO (``serve --rt-priority`` :data:`RT_PRIORITY`; the
  robot, this process and the busy one stay normal processes); ``realtime_refused`` instead,
  the one line, where the system refuses it;
* ``dds_busy_poll_network_after_answer``, ``dds_busy_core_busy_poll_network_after_answer``:
  ``dds_network_after_answer`` and ``dds_busy_core_network_after_answer`` again with the node
  polling instead of sleeping between messages (``serve --busy-poll``, a normal process: with
  SCHED_FIFO it is refused), its core kept warm at the cost of a whole core;
* ``node_network_after_answer_paced``: ``node_network_after_answer`` with each message handled
  1 ms after the one before and the process asleep in between, as at 1 kHz on the robot: the
  same work, woken from sleep each time (its caches cold) instead of back to back;
* ``dds_floor``, ``dds_floor_realtime``: ``dds`` for a third of the time with, in place of
  ``serve``, the same node without its estimator (``benchmarks/live_floor.py``: each HEX10
  message answered with four outputs encoded before and restamped), normal and under
  SCHED_FIFO: what any node of this design adds on this host, the floor under ``serve``'s
  figures;
* ``dds_rate_measured``: the same for 5 s without ``--input-rate`` (the node measures the rate
  from the first stamps): ``first_answer_ms`` is what a user starting the node sees;
* ``burst``: 5000 samples of the 1 kHz stream published at 10 times its rate (10 kHz for 0.5 s,
  messages encoded before, so the writes alone set the pace; the rate reached is recorded) to
  ``serve`` in another process: what the node received and answered, per stream;
  ``burst_busy_core``: the same while another process keeps one core busy;
* ``replay``: ``psmforce replay`` of a 1 kHz bag of the same session, as fast as it goes:
  input messages and answers per second (MCAP written).

Targets (issue 25): p99 end to end at most 1 ms, nothing lost, on this shared 2-core machine;
``machine.load_average`` records how busy it was.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from importlib.metadata import version  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402
from psmforce.experiments.report import write_json  # noqa: E402

from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator  # noqa: E402
from psmforce.robot import PSM  # noqa: E402
from psmforce.io.bags.messages import stream_columns  # noqa: E402
from psmforce.io.bags.reading import resolve_topics  # noqa: E402

PERIOD_MS = 1.0
"""The period of a 1 kHz loop: the budget of one message (ms)."""
TARGET_P99_MS = 1.0
RESIDENCE_GOAL_P99_MS = 0.3
"""Issue 47's goal for what the node adds (p99, ms); ``node_residence`` is measured against it."""
RT_PRIORITY = 50
"""``serve --rt-priority`` in the real-time runs: mid-range, below the kernel's own threads."""
BURST_SPEED = 10.0
"""A controller's burst after a hiccup: this many times the stream's rate (issue 47)."""
WARMUP = 500
START_NS = 1_700_000_000 * 10**9
BAD = Flags.GAP | Flags.RESET | Flags.INVALID_INPUT
ROOT = Path(__file__).resolve().parents[1]


def _percentiles(values_ms) -> dict:
    values = np.asarray(values_ms, dtype=float)
    return {"median_ms": float(np.median(values)), "p99_ms": float(np.percentile(values, 99)),
            "max_ms": float(values.max()), "n": len(values)}


def _checkpoint(tmp: Path) -> tuple[Path, str]:
    from psmforce.estimators.training.train import train
    from psmforce.sim import simulate
    simulate("automated", scale=0.01, seed=0, out=tmp / "bench")
    summary = train(tmp / "bench", "hybrid", tmp / "hybrid.pt", epochs=2, seed=0)
    return tmp / "hybrid.pt", (f"hybrid trained here: 1 %-scale simulated bench, seed 0, "
                               f"{summary['epochs_run']} epochs")


def _raw_messages(frame) -> list[tuple[str, bytes]]:
    """The robot's messages, per row, as the CDR bytes it writes
    (:meth:`psmforce.live.sim_robot.Robot.encode`): arm and jaw JointState, then HEX10
    WrenchStamped."""
    from psmforce.live.sim_robot import Robot
    values = {s: frame[list(stream_columns(s))].to_numpy(np.float64) for s in ("js", "jaw",
                                                                               "hex10")}
    stamps = START_NS + np.rint(frame["time"].to_numpy() * 1e9).astype(np.int64)
    out = []
    for k, stamp in enumerate(stamps):
        encoded = Robot.encode(int(stamp), {s: v[k] for s, v in values.items()})
        out += list(zip(("js", "jaw", "hex10"), encoded))
    return out


def _decoders() -> dict:
    """Per decoder, stream -> function of the CDR bytes: the project's (what ``serve`` uses)
    and ``cyclonedds``' Python classes (what a ``DataReader.take`` gives)."""
    from psmforce.live import cdr, dds
    return {"psmforce.live.cdr": {"js": cdr.Stream("JointState"), "jaw": cdr.Stream("JointState"),
                                  "hex10": cdr.Stream("WrenchStamped")},
            "cyclonedds": {"js": dds.JointState.deserialize, "jaw": dds.JointState.deserialize,
                           "hex10": dds.WrenchStamped.deserialize}}


def _messages(frame) -> list[tuple[str, object]]:
    """The robot's messages as ``serve`` hands them to the node (decoded from their bytes)."""
    decode = _decoders()["psmforce.live.cdr"]
    return [(s, decode[s](data)) for s, data in _raw_messages(frame)]


def decode_figures(frame) -> dict:
    """The time to decode one sample's three messages (arm, jaw, HEX10) from their bytes, per
    decoder, after :data:`WARMUP` samples (ms)."""
    raw = _raw_messages(frame)
    out = {}
    for name, decode in _decoders().items():
        times = []
        for k in range(0, len(raw), 3):
            t0 = time.perf_counter_ns()
            for stream, data in raw[k:k + 3]:
                decode[stream](data)
            times.append(time.perf_counter_ns() - t0)
        out[name] = _percentiles(np.array(times[WARMUP:]) * 1e-6)
    return out


def node_figures(ckpt: Path, frame, network_after_answer: bool = False,
                 paced: bool = False) -> dict:
    """``node`` (module docstring); ``paced``: each HEX10 message handled 1 ms after the one
    before, the process asleep in between, as the live node at 1 kHz."""
    from psmforce.live.node import ForceNode
    # the option only when asked: node_ab.py runs this on revisions that predate it
    order = {"network_after_answer": True} if network_after_answer else {}
    est = StreamingEstimator.from_checkpoint(ckpt, input_rate_hz=1000.0, psm=PSM(), **order)
    node = ForceNode(est)
    wall, cpu, after, flags = [], [], [], 0
    wall_clock, cpu_clock = time.perf_counter_ns, time.thread_time_ns
    due = wall_clock()
    for stream, message in _messages(frame):
        if paced and stream == "js":  # a sample's first message: wait for its millisecond
            due += 1_000_000
            time.sleep(max(0.0, (due - wall_clock()) * 1e-9))
        w0, c0 = wall_clock(), cpu_clock()
        answers = node.update(stream, message)
        for answer in answers:
            node.encode(answer)
        w1, c1 = wall_clock(), cpu_clock()
        if network_after_answer:  # the step an answer deferred, once the answer is out
            est.advance()
        if stream == "hex10":
            after.append(wall_clock() - w1)
            wall.append(w1 - w0)
            cpu.append(c1 - c0)
            flags |= answers[0].flags
    if flags & BAD:
        raise RuntimeError(f"the stream was not clean (flags {Flags(flags & BAD)!r}): the "
                           f"network-step split would not hold")
    wall, cpu = np.array(wall) * 1e-6, np.array(cpu) * 1e-6
    k = np.arange(len(wall))
    network = (k % est.decimation == 0) & (k >= WARMUP)
    other = (k % est.decimation != 0) & (k >= WARMUP)
    out = {"messages": int(len(wall) - WARMUP), "backend": est.backend_name,
           "decimation": est.decimation, "model_rate_hz": est.rate_hz,
           "input_rate_hz": est.input_rate_hz, "lag_s": est.lag_s(), "budget_ms": PERIOD_MS,
           "network_after_answer": network_after_answer, "paced": paced}
    for name, mask in (("all", k >= WARMUP), ("network_steps", network),
                       ("physics_and_filter_only", other)):
        out[name] = {**_percentiles(wall[mask]),
                     "cpu": {k2: v for k2, v in _percentiles(cpu[mask]).items() if k2 != "n"},
                     "over_budget_fraction": float((wall[mask] > PERIOD_MS).mean())}
    if network_after_answer:  # the deferred steps, after the answers of the messages they follow
        out["after_the_answer"] = _percentiles(np.array(after)[network] * 1e-6)
    return out


def network_after_answer_accuracy(frame) -> dict:
    """What answering before the network step costs the estimate: the shipped bench model
    (:mod:`psmforce.live.bench_model`) over the session, per axis, its NRMSE against the ATI
    (% of the ATI's range, after its warm-up) with the network before and after the answer, and
    how far the two estimates lie apart (N)."""
    from psmforce.io.recording import TARGETS
    from psmforce.live.bench_model import shipped_checkpoint
    ckpt = shipped_checkpoint()
    estimates = {order: StreamingEstimator.from_checkpoint(
        ckpt, input_rate_hz=1000.0, network_after_answer=order == "after_answer"
    ).predict_recording(frame) for order in ("before_answer", "after_answer")}
    settled = slice(WARMUP, None)
    truth = frame[list(TARGETS)].to_numpy(np.float64)[settled]
    span = truth.max(axis=0) - truth.min(axis=0)
    nrmse = {order: (100 * np.sqrt(((e[settled] - truth) ** 2).mean(axis=0)) / span).tolist()
             for order, e in estimates.items()}
    apart = estimates["after_answer"][settled] - estimates["before_answer"][settled]
    return {"checkpoint": "the shipped bench model (psmforce/live/data)",
            "axes": list(TARGETS), "nrmse_percent": nrmse,
            "difference_rms_N": np.sqrt((apart ** 2).mean(axis=0)).tolist(),
            "difference_max_N": np.abs(apart).max(axis=0).tolist()}


def _cpu_s(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (s)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def realtime_refusal() -> str | None:
    """Why this system refuses ``serve --rt-priority`` (asked of a fresh process), or None."""
    code = ("from psmforce.live.scheduling import run_realtime\n"
            f"try:\n    run_realtime({RT_PRIORITY})\n"
            "except ValueError as err:\n    raise SystemExit(str(err))")
    probe = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)
    return None if probe.returncode == 0 else (probe.stderr.strip().splitlines() or ["?"])[-1]


def dds_figures(ckpt: Path, frame, seconds: float, tmp: Path, *, input_rate: bool = True,
                busy_core: bool = False, network: str = "before-answer",
                rt_priority: int | None = None, floor: bool = False,
                busy_poll: bool = False) -> dict:
    from cyclonedds.core import (
        InstanceState,
        Policy,
        Qos,
        ReadCondition,
        SampleState,
        ViewState,
        WaitSet,
    )
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    from psmforce.io.recording import write_recording
    from psmforce.live import cdr, dds
    from psmforce.live.node import output_topics
    domain_id = 150 + os.getpid() % 80
    write_recording(frame, tmp / "robot.csv")
    participant = DomainParticipant(domain_id)
    qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
              Policy.History.KeepLast(dds.DEPTH))
    reader = DataReader(participant, Topic(participant, dds.dds_topic(output_topics()["hex10"]),
                                           dds.WrenchStamped), qos=qos)
    # the robot's HEX10 messages themselves, taken in the same loop: the transport without
    # the node, on the same machine at the same moment
    direct = DataReader(participant, Topic(participant, dds.dds_topic(
        resolve_topics("PSM1", {})[0]["hex10"]), dds.WrenchStamped), qos=qos)
    waitset = WaitSet(participant)
    for r in (reader, direct):
        waitset.attach(ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    realtime = ["--rt-priority", str(rt_priority)] if rt_priority is not None else []
    command = ([str(ROOT / "benchmarks" / "live_floor.py"), str(ckpt), "--domain-id",
                str(domain_id), *realtime] if floor else
               ["-m", "psmforce.cli.main", "serve", str(ckpt), "--domain-id", str(domain_id),
                *(["--input-rate", "1000"] if input_rate else []), "--sync-stamps",
                "--idle-stop", "3", *(["--network", network] if network != "before-answer"
                                       else []), *realtime,
                *(["--busy-poll"] if busy_poll else [])])
    node = subprocess.Popen([sys.executable, *command, "--json", str(tmp / "node.json")],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    robot = burner = None
    received: dict[int, int] = {}
    received_direct: dict[int, int] = {}
    try:
        deadline = time.monotonic() + 180
        while not reader.get_matched_publications():
            if node.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"psmforce serve did not come up: {node.communicate()}")
            time.sleep(0.05)
        if busy_core:  # one core kept busy by another process all through the playback
            burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        robot = subprocess.Popen(
            [sys.executable, "-m", "psmforce.live.sim_robot", str(tmp / "robot.csv"), "--domain-id",
             str(domain_id), "--start-ns", str(START_NS), "--duration", str(seconds),
             "--sent", str(tmp / "sent.json")], env=env, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True)
        cpu0, wall0 = _cpu_s(node.pid), time.monotonic()
        cpu1 = wall1 = None
        last = time.monotonic()
        while time.monotonic() - last < 2.0 or robot.poll() is None:
            waitset.wait(duration(milliseconds=50))
            now_ns = time.time_ns()
            for data, _ in dds.take_raw(reader, 4096):  # decoded as the node decodes
                stamp = cdr.decode_wrench_stamped(data).header.stamp
                received[stamp.sec * 10**9 + stamp.nanosec] = now_ns
                last = time.monotonic()
            for data, _ in dds.take_raw(direct, 4096):
                stamp = cdr.decode_wrench_stamped(data).header.stamp
                received_direct[stamp.sec * 10**9 + stamp.nanosec] = now_ns
            if cpu1 is None and robot.poll() is not None:
                cpu1, wall1 = _cpu_s(node.pid), time.monotonic()
        if robot.returncode != 0:
            raise RuntimeError(f"the robot failed: {robot.communicate()[1]}")
        node.communicate(timeout=60)
    finally:
        for process in (robot, node, burner):
            if process is not None and process.poll() is None:
                process.kill()
    sent = json.loads((tmp / "sent.json").read_text())
    report = json.loads((tmp / "node.json").read_text())
    latency = [(received[s] - w) * 1e-6 for s, w in zip(sent["stamps_ns"], sent["sent_ns"])
               if s in received]
    transport = [(received_direct[s] - w) * 1e-6
                 for s, w in zip(sent["stamps_ns"], sent["sent_ns"]) if s in received_direct]
    added = [(received[s] - received_direct[s]) * 1e-6 for s in sent["stamps_ns"]
             if s in received and s in received_direct]
    first_answer = min(received.values()) - sent["sent_ns"][0] if received else None
    n = len(sent["stamps_ns"])
    return {"seconds": seconds, "input_rate_given": input_rate, "busy_core": busy_core,
            "node": "floor (benchmarks/live_floor.py)" if floor else "psmforce serve",
            "network": network, "scheduling": report.get("scheduling"), "busy_poll": busy_poll,
            "hex10_sent": n,
            "node_received": report["received"]["hex10"],
            "node_lost": n - report["received"]["hex10"],
            "node_added_latency": _percentiles(added),
            "node_residence": report["residence_ms"],
            "node_residence_writes": report.get("residence_writes_ms"),
            "residence_goal_p99_ms": RESIDENCE_GOAL_P99_MS,
            "residence_goal_met": report["residence_ms"]["p99_ms"] <= RESIDENCE_GOAL_P99_MS,
            "first_answer_ms": None if first_answer is None else first_answer * 1e-6,
            "answers_published": report["answers_published"], "answers_received": len(latency),
            "lost_fraction": 1.0 - len(latency) / n, "unpaired": report["unpaired"],
            "latency": _percentiles(latency), "transport_latency": _percentiles(transport),
            "within_target": bool(np.percentile(latency, 99) <= TARGET_P99_MS
                                  and len(latency) == n),
            "node_cpu_fraction": (cpu1 - cpu0) / (wall1 - wall0),
            "flag_counts": report["flag_counts"]}


def burst_figures(ckpt: Path, frame, tmp: Path, samples: int = 5000,
                  busy_core: bool = False) -> dict:
    """``samples`` of the 1 kHz session published by this process at :data:`BURST_SPEED` times
    the stream's rate (as a controller sends after a hiccup) to ``serve`` in another process,
    optionally while another process keeps one core busy; what the node received and
    answered."""
    from cyclonedds.domain import DomainParticipant

    from psmforce.live.sim_robot import play
    domain_id = 150 + (os.getpid() + 40 + 7 * busy_core) % 80
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    node = subprocess.Popen(
        [sys.executable, "-m", "psmforce.cli.main", "serve", str(ckpt), "--domain-id",
         str(domain_id), "--input-rate", "1000", "--idle-stop", "3", "--duration", "300",
         "--json", str(tmp / "burst.json")], env=env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    burner = None
    try:
        node.stdout.readline()  # listening
        if busy_core:
            burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        burst = frame.iloc[:samples]
        sent = play(burst, DomainParticipant(domain_id), realtime=True, speed=BURST_SPEED,
                    start_ns=START_NS)["sent_ns"]
        seconds = (sent[-1] - sent[0]) * 1e-9
        node.communicate(timeout=300)
    finally:
        for process in (node, burner):
            if process is not None and process.poll() is None:
                process.kill()
    report = json.loads((tmp / "burst.json").read_text())
    return {"samples": samples, "busy_core": busy_core, "asked_times_the_stream_rate":
            BURST_SPEED, "seconds": seconds, "rate_hz": (samples - 1) / seconds,
            "times_the_stream_rate": (samples - 1) / seconds / 1000.0,
            "node_received": report["received"], "node_lost":
                {s: samples - n for s, n in report["received"].items() if s != "tare"},
            "answers_published": report["answers_published"],
            "node_residence": report["residence_ms"]}


def replay_figures(ckpt: Path, frame, tmp: Path) -> dict:
    from psmforce.io.bags.writing import write_bag
    from psmforce.live.replay import replay
    write_bag(frame, tmp / "session", start_ns=START_NS)
    started = time.perf_counter()
    report = replay(tmp / "session", ckpt, tmp / "out.mcap")
    seconds = time.perf_counter() - started
    return {"session_s": float(frame["time"].iloc[-1] - frame["time"].iloc[0]),
            "inputs": report["inputs_copied"], "answers": report["answers"],
            "seconds": seconds, "inputs_per_s": report["inputs_copied"] / seconds,
            "answers_per_s": report["answers"] / seconds,
            "realtime_factor": float(frame["time"].iloc[-1]) / seconds}


def main() -> tuple[dict, str | None]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint")
    parser.add_argument("--seconds", type=float, default=60.0,
                        help="how long the robot publishes over DDS (default 60)")
    parser.add_argument("--json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    from psmforce.live.sim_robot import bench_recording
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        result = {"machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                              "python": platform.python_version(), "torch": torch.__version__,
                              "cyclonedds": version("cyclonedds"),
                              "load_average": list(os.getloadavg())}}
        if args.checkpoint:
            ckpt, label = Path(args.checkpoint), "given (--checkpoint)"
        else:
            ckpt, label = _checkpoint(tmp)
        est = StreamingEstimator.from_checkpoint(ckpt)
        result["checkpoint"] = {"what": label, "model_rate_hz": est.rate_hz,
                                "window": est.window,
                                "parameters": sum(p.numel() for p in est.model.parameters())}
        frame = bench_recording(1000.0)
        result["session"] = {"rate_hz": 1000.0, "samples": len(frame),
                             "seconds": float(frame["time"].iloc[-1])}
        result["decode"] = decode_figures(frame)
        result["node"] = node_figures(ckpt, frame)
        result["node_network_after_answer"] = node_figures(ckpt, frame, True)
        result["node_network_after_answer_paced"] = node_figures(ckpt, frame, True, paced=True)
        result["network_after_answer_accuracy"] = network_after_answer_accuracy(frame)
        result["dds"] = dds_figures(ckpt, frame, args.seconds, tmp)
        result["dds_network_after_answer"] = dds_figures(ckpt, frame, args.seconds, tmp,
                                                         network="after-answer")
        result["dds_busy_core"] = dds_figures(ckpt, frame, args.seconds / 3, tmp,
                                              busy_core=True)
        result["dds_busy_core_network_after_answer"] = dds_figures(
            ckpt, frame, args.seconds / 3, tmp, busy_core=True, network="after-answer")
        refused = realtime_refusal()
        if refused is None:
            for network in ("before-answer", "after-answer"):
                tail = "" if network == "before-answer" else "_network_after_answer"
                result[f"dds_realtime{tail}"] = dds_figures(
                    ckpt, frame, args.seconds, tmp, network=network, rt_priority=RT_PRIORITY)
                result[f"dds_busy_core_realtime{tail}"] = dds_figures(
                    ckpt, frame, args.seconds / 3, tmp, busy_core=True, network=network,
                    rt_priority=RT_PRIORITY)
        else:
            result["realtime_refused"] = refused
        result["dds_busy_poll_network_after_answer"] = dds_figures(
            ckpt, frame, args.seconds, tmp, network="after-answer", busy_poll=True)
        result["dds_busy_core_busy_poll_network_after_answer"] = dds_figures(
            ckpt, frame, args.seconds / 3, tmp, busy_core=True, network="after-answer",
            busy_poll=True)
        # the floor: the same node without its estimator (benchmarks/live_floor.py)
        result["dds_floor"] = dds_figures(ckpt, frame, args.seconds / 3, tmp, floor=True)
        if refused is None:
            result["dds_floor_realtime"] = dds_figures(ckpt, frame, args.seconds / 3, tmp,
                                                       floor=True, rt_priority=RT_PRIORITY)
        result["dds_rate_measured"] = dds_figures(ckpt, frame, 5.0, tmp, input_rate=False)
        result["burst"] = burst_figures(ckpt, frame, tmp)
        result["burst_busy_core"] = burst_figures(ckpt, frame, tmp, busy_core=True)
        result["replay"] = replay_figures(ckpt, frame, tmp)
        result["machine"]["load_average_after"] = list(os.getloadavg())
    return result, args.json


def _print(r: dict) -> None:
    node, link, rep = r["node"], r["dds"], r["replay"]
    print(f"checkpoint: {r['checkpoint']['what']}; model at {node['model_rate_hz']:g} Hz, input "
          f"{node['input_rate_hz']:g} Hz (decimation {node['decimation']}, lag "
          f"{node['lag_s'] * 1e3:.1f} ms), backend {node['backend']}")
    for name in ("all", "network_steps", "physics_and_filter_only"):
        s = node[name]
        print(f"ForceNode per HEX10 message, {name:24s}: median {s['median_ms']:.3f} ms, p99 "
              f"{s['p99_ms']:.3f} ms, max {s['max_ms']:.2f} ms (budget {PERIOD_MS:g} ms; over "
              f"it: {100 * s['over_budget_fraction']:.2f} %)")
    for name, d in r["decode"].items():
        print(f"decoding one sample's three messages, {name:17s}: median "
              f"{1e3 * d['median_ms']:.1f} us, p99 {1e3 * d['p99_ms']:.1f} us")
    lat = link["latency"]
    print(f"serve over DDS, {link['seconds']:g} s at 1 kHz: {link['hex10_sent']} sent, "
          f"{link['answers_received']} answers received, lost {100 * link['lost_fraction']:.3f} "
          f"%; latency p50 {lat['median_ms']:.3f} ms, p99 {lat['p99_ms']:.3f} ms, max "
          f"{lat['max_ms']:.2f} ms (the robot's own messages to this process, no node: p50 "
          f"{link['transport_latency']['median_ms']:.3f} ms, p99 "
          f"{link['transport_latency']['p99_ms']:.3f} ms); node CPU "
          f"{100 * link['node_cpu_fraction']:.0f} % of a core; "
          f"target (p99 <= {TARGET_P99_MS:g} ms, none lost) "
          f"{'met' if link['within_target'] else 'NOT met'}")
    added, own = link["node_added_latency"], link["node_residence"]
    print(f"node-added latency (answer minus the robot's own message, per message): p50 "
          f"{added['median_ms']:.3f} ms, p99 {added['p99_ms']:.3f} ms, max "
          f"{added['max_ms']:.2f} ms")
    writes = link["node_residence_writes"]
    print(f"of which the DDS writes: p50 {writes['median_ms']:.3f} ms, p99 {writes['p99_ms']:.3f} "
          f"ms, max {writes['max_ms']:.2f} ms")
    print(f"the node's residence (taken to written, its own clock): p50 {own['median_ms']:.3f} "
          f"ms, p99 {own['p99_ms']:.3f} ms, max {own['max_ms']:.2f} ms (goal p99 <= "
          f"{RESIDENCE_GOAL_P99_MS:g} ms: {'met' if link['residence_goal_met'] else 'NOT met'})")
    for name in ("dds_network_after_answer", "dds_busy_core_network_after_answer"):
        after = r[name]
        print(f"{name}: node residence p50 {after['node_residence']['median_ms']:.3f} ms, p99 "
              f"{after['node_residence']['p99_ms']:.3f} ms; node-added latency p99 "
              f"{after['node_added_latency']['p99_ms']:.3f} ms; node lost {after['node_lost']}")
    acc = r["network_after_answer_accuracy"]
    print(f"the network after the answer, shipped bench model on the session: NRMSE % before "
          f"{[round(v, 2) for v in acc['nrmse_percent']['before_answer']]}, after "
          f"{[round(v, 2) for v in acc['nrmse_percent']['after_answer']]}")
    busy = r["dds_busy_core"]
    print(f"one core busy, {busy['seconds']:g} s: {busy['hex10_sent']} sent, node lost "
          f"{busy['node_lost']}, answers lost {100 * busy['lost_fraction']:.3f} %, latency p99 "
          f"{busy['latency']['p99_ms']:.2f} ms")
    print(f"first answer without --input-rate: {r['dds_rate_measured']['first_answer_ms']:.1f} ms "
          f"after the robot's first HEX10 message (with it: {link['first_answer_ms']:.1f} ms)")
    for name in ("burst", "burst_busy_core"):
        b = r[name]
        print(f"{name}: {b['samples']} samples at {b['rate_hz']:.0f} Hz "
              f"({b['times_the_stream_rate']:.1f}x, asked {b['asked_times_the_stream_rate']:g}x), "
              f"node lost {b['node_lost']}, answered {b['answers_published']}")
    print(f"replay: {rep['inputs_per_s']:.0f} input messages/s, {rep['answers_per_s']:.0f} "
          f"answers/s ({rep['realtime_factor']:.1f}x real time)")
    print(f"load average before / after: {r['machine']['load_average']} / "
          f"{r['machine']['load_average_after']}")


if __name__ == "__main__":
    figures, json_path = main()
    _print(figures)
    if json_path:
        write_json(json_path, figures)
