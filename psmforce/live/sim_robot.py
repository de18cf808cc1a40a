"""A robot to try the node on without a robot: a recording played over DDS as the dVRK and the
HEX10 publish it (``psmforce serve --sim``, the end-to-end test, ``benchmarks/live.py``).

:func:`play` publishes, per row of a recording (:mod:`psmforce.io.recording`), the arm's
sensor_msgs/JointState (the six chain joints, dVRK >= 2024 names and order), the jaw's (one joint
``jaw``) and the HEX10's geometry_msgs/WrenchStamped (``frame_id`` ``hex10``), in that order, on
the CRTK topics of :func:`psmforce.io.bags.reading.default_topics` (or the ones given), each header
stamped ``start_ns`` + the row's ``time``; paced in real time by default (``speed``: that many
times faster, a controller's burst). Messages are encoded by :mod:`psmforce.live.cdr` and written
as they are (QoS: :func:`psmforce.live.dds.qos`); a recording played once is encoded before the
first write, so the writes alone set the pace a burst reaches.
:func:`bench_recording` simulates a short bench session (:mod:`psmforce.sim`) and puts it on the
clock a dVRK publishes at (linear interpolation onto ``rate_hz``).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.core.files import write_text_atomic
from psmforce.io.bags.messages import stream_columns
from psmforce.io.bags.reading import resolve_topics
from psmforce.robot.conventions import CHAIN_JOINTS, JAW_JOINT
from psmforce.io.recording import TIME, read_recording
from psmforce.live import cdr


def bench_recording(rate_hz: float = 1000.0, seed: int = 0) -> pd.DataFrame:
    """A simulated palpation session (about 10 s; the bench runs at 100 Hz) on a ``rate_hz``
    clock."""
    from psmforce.sim import simulate
    with tempfile.TemporaryDirectory() as tmp:
        simulate(protocol="automated", scale=0.01, seed=seed, out=Path(tmp) / "bench")
        files = sorted((Path(tmp) / "bench" / "test" / "Palpation").glob("*.csv"))
        frame = max((read_recording(f) for f in files), key=len)
    t = frame[TIME].to_numpy()
    clock = np.arange(0.0, t[-1], 1.0 / rate_hz)
    return pd.DataFrame({c: np.interp(clock, t, frame[c].to_numpy(float))
                         for c in frame.columns if c == TIME or frame[c].dtype.kind == "f"}
                        ).assign(**{TIME: clock})


class Robot:
    """DDS writers of the robot's three streams (module docstring)."""

    def __init__(self, participant, *, arm: str = "PSM1", topics: dict | None = None,
                 best_effort: bool = False):
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        from psmforce.live import dds
        resolved, _ = resolve_topics(arm, {k: v for k, v in (topics or {}).items()
                                           if k in ("js", "jaw", "hex10")})
        self.topics = {s: resolved[s] for s in ("js", "jaw", "hex10")}
        kinds = {"js": "sensor_msgs/msg/JointState", "jaw": "sensor_msgs/msg/JointState",
                 "hex10": "geometry_msgs/msg/WrenchStamped"}
        self.writers = {s: DataWriter(participant, Topic(participant, dds.dds_topic(t),
                                                         dds.TYPES[kinds[s]]),
                                      qos=dds.qos(best_effort, kinds[s]))
                        for s, t in self.topics.items()}

    def wait_for_readers(self, timeout_s: float = 10.0) -> bool:
        """Wait until every stream has a matched reader (False on timeout)."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if all(w.get_matched_subscriptions() for w in self.writers.values()):
                return True
            time.sleep(0.02)
        return False

    @staticmethod
    def encode(stamp_ns: int, values: dict[str, np.ndarray]) -> tuple[bytes, bytes, bytes]:
        """One sample's js, jaw and hex10 messages (``values``: each stream's
        :func:`stream_columns` values) as their CDR bytes."""
        js, jaw, hex10 = values["js"], values["jaw"], values["hex10"]
        return (cdr.joint_state(stamp_ns, "", CHAIN_JOINTS, js[0:6], js[6:12], js[12:18]),
                cdr.joint_state(stamp_ns, "", (JAW_JOINT,), jaw[0:1], jaw[1:2], jaw[2:3]),
                cdr.wrench_stamped(stamp_ns, "hex10", hex10[:3], hex10[3:]))

    def write(self, encoded: tuple[bytes, bytes, bytes]) -> int:
        """Write one sample's bytes (:meth:`encode`) in stream order; returns the wall time
        (ns) the HEX10 message was written."""
        from psmforce.live.dds import write_raw
        write_raw(self.writers["js"], encoded[0])
        write_raw(self.writers["jaw"], encoded[1])
        sent = time.time_ns()
        write_raw(self.writers["hex10"], encoded[2])
        return sent

    def publish(self, stamp_ns: int, values: dict[str, np.ndarray]) -> int:
        """One sample, encoded and written (:meth:`encode`, :meth:`write`)."""
        return self.write(self.encode(stamp_ns, values))


def play(frame: pd.DataFrame, participant, *, arm: str = "PSM1", topics: dict | None = None,
         start_ns: int | None = None, realtime: bool = True, loop: bool = False,
         wait_s: float = 10.0, best_effort: bool = False, stop=None, speed: float = 1.0
         ) -> dict:
    """Publish ``frame`` as the robot (module docstring). ``start_ns``: the stamp of ``time``
    0 (default: now). ``loop``: start over at the end (stamps keep increasing) until ``stop``
    (a ``threading.Event`` or similar) is set. ``speed``: with ``realtime``, the pace is the
    recording's times ``speed`` (stamps unchanged). Returns the stamps and HEX10 write times
    (ns)."""
    if not speed > 0:
        raise ValueError(f"speed must be > 0, got {speed!r}")
    robot = Robot(participant, arm=arm, topics=topics, best_effort=best_effort)
    if not robot.wait_for_readers(wait_s):
        raise RuntimeError(f"no node subscribed to {sorted(robot.topics.values())} within "
                           f"{wait_s:g} s")
    values = {s: frame[list(stream_columns(s))].to_numpy(np.float64) for s in robot.writers}
    t = frame[TIME].to_numpy(np.float64) - float(frame[TIME].iloc[0])
    period = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    start_ns = time.time_ns() if start_ns is None else int(start_ns)
    stamps, sent = [], []
    rows = [{s: v[k] for s, v in values.items()} for k in range(len(t))]
    once = None if loop else [robot.encode(start_ns + int(round(t[k] * 1e9)), rows[k])
                              for k in range(len(t))]
    offset, t0 = 0.0, time.monotonic()
    while True:
        for k in range(len(t)):
            if stop is not None and stop.is_set():
                return {"stamps_ns": stamps, "sent_ns": sent}
            due = offset + t[k]
            if realtime:
                delay = t0 + due / speed - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            stamp = start_ns + int(round(due * 1e9))
            sent.append(robot.write(once[k]) if once else robot.publish(stamp, rows[k]))
            stamps.append(stamp)
        if not loop:
            return {"stamps_ns": stamps, "sent_ns": sent}
        offset += t[-1] + period


def main(argv: list[str] | None = None) -> int:
    """``python -m psmforce.live.sim_robot RECORDING.csv [--domain-id N] [--start-ns NS]
    [--duration S]``: play a recording as the robot, in real time, once (or looped for S
    seconds), and print how many samples went out."""
    import argparse
    import json

    from psmforce.live.discovery import participant
    parser = argparse.ArgumentParser(prog="python -m psmforce.live.sim_robot")
    parser.add_argument("recording")
    parser.add_argument("--domain-id", type=int)
    parser.add_argument("--start-ns", type=int)
    parser.add_argument("--arm", default="PSM1")
    parser.add_argument("--duration", type=float, metavar="S",
                        help="loop the recording for S seconds (default: play it once)")
    parser.add_argument("--sent", help="write the stamps and HEX10 write times (ns) here")
    args = parser.parse_args(argv)
    frame = read_recording(args.recording, require_targets=False)
    stop = None
    if args.duration is not None:
        import threading
        stop = threading.Event()
        threading.Timer(args.duration, stop.set).start()  # the wait for a node included
    result = play(frame, participant(args.domain_id), arm=args.arm,
                  start_ns=args.start_ns, loop=stop is not None, stop=stop)
    if args.sent:
        write_text_atomic(args.sent, json.dumps(result))
    print(f"published {len(result['stamps_ns'])} samples")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
