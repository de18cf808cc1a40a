"""``psmforce serve``: the live force node over DDS (``cyclonedds``, extra ``psmforce[ros]``).

:class:`DdsNode` subscribes (:mod:`psmforce.live.dds`: ROS 2 topic and type names, QoS) to the
arm's joint states, the jaw's and the HEX10 wrench (CRTK names by default, each overridable as
in ``convert``) and to the tare topic, and hands every message to a
:class:`psmforce.live.node.ForceNode`, which answers each HEX10 message; the answers are
published on the node's output topics (:func:`psmforce.live.node.output_topics`) as the
:mod:`psmforce.live.cdr` bytes.

Order. The node wakes when a HEX10 or tare message arrives (with ``sync``, any message), and at
least every 50 ms; on each wake-up every reader is emptied, the HEX10's first, and the messages
are handled in the order they were written (their DDS source timestamps), so each HEX10 message
meets the joint states published before it (from one publisher, which delivers in order, as
the simulated robot; separate publishers, as on the dVRK, race as any subscriber does); a joint
state that arrives after a HEX10 message is handled before the next one, as it would have
been had it woken the node; none is dropped (the readers keep
:data:`psmforce.live.dds.DEPTH`).

Decoding. Messages are taken as their CDR bytes and decoded by :mod:`psmforce.live.cdr`, not by
the middleware's Python classes (``benchmarks/live.py`` times both), a
:class:`psmforce.live.cdr.Stream` per reader: a stream's frame and joint names are decoded once,
not at every message. A message whose bytes do not decode is counted (``malformed`` in
:meth:`DdsNode.report`, its reason printed once per stream) and skipped: the node goes on with
the stream's previous message, flagged STALE if none follows.

Rate. The estimator, with its network's backend (the slow part: the step graph is compiled), is
built before the node subscribes, at ``input_rate_hz`` when given, else at the model's rate.
Without ``input_rate_hz`` the first :data:`RATE_MESSAGES` HEX10 messages are held back while their
header stamps measure the input rate (:func:`psmforce.estimators.data.rates.stream_rate_hz`: a
repeated, backward or unset stamp among them is set aside, and flagged when its message is
answered), the estimator is set to it
(:meth:`psmforce.estimators.runtime.streaming.StreamingEstimator.set_input_rate`: microseconds),
and the held messages are answered in order: the first answer follows the fifth HEX10 message
by well under a millisecond of work, nothing is lost. A rate the model cannot serve stops the
node with one line.

Residence. The node's own share of the latency, apart from the transport's: per answer, from
the moment its HEX10 message was taken from the reader to the moment its last output was
written (``time.perf_counter_ns``, the node's clock), kept for the last :data:`RESIDENCE_KEPT`
answers and reported as ``residence_ms`` (median, p99, max): the work of the answer and of the
messages taken with it ahead of it, none of the transport's or the other processes'. With
``network_after_answer`` (an option of the estimator, passed through ``options``; ``serve
--network after-answer``) the network step an answer owes runs once its outputs are written,
outside that answer's residence; a message that arrives meanwhile waits in its reader, which its
own residence does not count either (``benchmarks/live.py``'s ``node_added_latency`` does).
``residence_writes_ms``: the same answers' time in the DDS writes alone (four per answer).

Waiting. Between messages the node sleeps in the middleware's wait set, and each message wakes
it on a core whose caches and clock the host has meanwhile given to others: its first
microseconds run slow. With ``busy_poll`` (``serve --busy-poll``) it polls the wait set instead,
never sleeping, and answers on a warm core: a shorter residence tail for a whole core's time,
the trade of a real-time loop on a core set aside for it (``isolcpus``, docs/live.md). Under a
real-time policy it is refused (:func:`psmforce.live.scheduling.check_busy_poll`); each poll
yields the core to any other runnable thread, the middleware's receive threads among them.

The participant it is given joins the domain as a ROS 2 node would
(:mod:`psmforce.live.discovery`).
"""

from __future__ import annotations

import os
import sys
import threading
import time

import numpy as np

from psmforce.estimators.data.rates import stream_rate_hz
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.io.bags.messages import stamp_ns
from psmforce.io.bags.reading import resolve_topics
from psmforce.live import cdr
from psmforce.live.node import (OUTPUT_TYPES, TARE_TYPE, ForceNode, check_sync_wait,
                                 output_topics)
from psmforce.live.scheduling import check_busy_poll

RESIDENCE_KEPT = 1 << 17
"""Answers whose residence time is kept (2 min at 1 kHz), the latest ones."""
RATE_MESSAGES = 5
"""HEX10 messages held back to measure the input rate (4 ms at 1 kHz): the median of their four
steps, which one bad stamp cannot move."""


class DdsNode:
    """The live node (module docstring). ``topics``: stream -> topic overrides (js, jaw,
    hex10); ``sync``: pair the streams by stamp (:class:`psmforce.live.node.ForceNode`);
    ``sync_wait_s``: with ``sync``, how long a trigger waits for its partners (``max_wait_s`` of
    :class:`psmforce.live.node.ForceNode`); ``busy_poll``: wait for messages by polling the
    wait set, never sleeping (module docstring, Waiting); ``options``: more keyword arguments of
    :meth:`psmforce.estimators.runtime.streaming.StreamingEstimator.from_checkpoint`
    (post_filter, backend)."""

    def __init__(self, checkpoint, participant, *, arm: str = "PSM1",
                 topics: dict | None = None, input_rate_hz: float | None = None,
                 tare_on_start: bool = False, tare_s: float = 0.5,
                 reader_best_effort: bool = False, writer_best_effort: bool = False,
                 sync: bool = False, sync_wait_s: float = 0.1, domain_id: int = 0,
                 busy_poll: bool = False, **options):
        from cyclonedds.core import (
            InstanceState,
            ReadCondition,
            SampleState,
            ViewState,
            WaitSet,
        )
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        from psmforce.live import dds
        self.checkpoint, self.arm, self.options = checkpoint, arm, options
        self.input_rate_hz, self.tare_on_start, self.tare_s = input_rate_hz, tare_on_start, tare_s
        check_sync_wait(sync_wait_s)  # before subscribing, not once the node is built
        self.sync, self.sync_wait_s = sync, sync_wait_s
        if busy_poll:
            check_busy_poll()
        self.busy_poll = busy_poll
        self.node: ForceNode | None = None
        self._held: list[tuple[str, object, int]] = []
        self._estimator = self._build_estimator(input_rate_hz)  # refused now, not at a message
        if input_rate_hz is not None:
            self.node = self._node()
        resolved, _ = resolve_topics(arm, {k: v for k, v in (topics or {}).items()
                                           if k in ("js", "jaw", "hex10")})
        self.input_topics = {s: resolved[s] for s in ("js", "jaw", "hex10")}
        self.output_topics = output_topics(arm)
        kinds = {"js": "sensor_msgs/msg/JointState", "jaw": "sensor_msgs/msg/JointState",
                 "hex10": "geometry_msgs/msg/WrenchStamped", "tare": TARE_TYPE}
        sources = {**self.input_topics, "tare": self.output_topics["tare"]}
        self.readers = {s: DataReader(participant, Topic(participant, dds.dds_topic(t),
                                                         dds.TYPES[kinds[s]]),
                                      qos=dds.qos(reader_best_effort, kinds[s], reader=True))
                        for s, t in sources.items()}
        self.writers = {name: DataWriter(participant, Topic(
            participant, dds.dds_topic(self.output_topics[name]), dds.TYPES[msgtype]),
            qos=dds.qos(writer_best_effort, msgtype)) for name, msgtype in OUTPUT_TYPES.items()}
        self.watch = dds.EndpointWatch(
            {self.input_topics[s]: self.readers[s] for s in self.input_topics},
            {self.output_topics[n]: w for n, w in self.writers.items()}, domain_id,
            time.monotonic())
        self.warnings: list[str] = []
        """What :attr:`watch` said (printed on stderr as it appeared)."""
        self._waitset = WaitSet(participant)
        mask = SampleState.Any | ViewState.Any | InstanceState.Any
        # woken by the HEX10 and the tare only (module docstring, Order): the joint states it
        # answers with were published before it and are taken in the same wake-up, a third
        # of the wake-ups; pairing by stamp waits for late partners, so every reader wakes it
        for stream, reader in self.readers.items():
            if sync or stream in ("hex10", "tare"):
                self._waitset.attach(ReadCondition(reader, mask))
        self._write, self._take = dds.write_raw, dds.take_raw
        self._take_order = ("hex10", "tare", "jaw", "js")
        self._decode = {"js": cdr.Stream("JointState"), "jaw": cdr.Stream("JointState"),
                        "hex10": cdr.Stream("WrenchStamped"), "tare": lambda data: None}
        self.received = {s: 0 for s in sources}
        self.malformed = {s: 0 for s in sources}
        self.published = 0
        self.last_answer = None
        self._flag_values: dict[int, int] = {}
        """Answers per flags value (counted per bit in :meth:`report`)."""
        self._taken_ns: dict[int, int] = {}
        """Stamp -> when its HEX10 message was taken, until it is answered (module docstring,
        Residence)."""
        self._residence_ns = np.zeros(RESIDENCE_KEPT, np.int64)
        self._writes_ns = np.zeros(RESIDENCE_KEPT, np.int64)
        """Per answer, the part of its residence spent writing its outputs."""
        self._residences = 0

    def _build_estimator(self, rate_hz: float | None) -> StreamingEstimator:
        from psmforce.robot import PSM
        return StreamingEstimator.from_checkpoint(self.checkpoint, input_rate_hz=rate_hz,
                                                  psm=PSM(), **self.options)

    def _node(self) -> ForceNode:
        node = ForceNode(self._estimator, arm=self.arm, tare_s=self.tare_s, sync=self.sync,
                         max_wait_s=self.sync_wait_s)
        if self.tare_on_start:
            node.request_tare()
        return node

    def _handle(self, stream: str, message, taken_ns: int) -> None:
        if stream == "tare":
            self.node.request_tare()
            return
        if stream == "hex10":
            self._taken_ns[stamp_ns(message) or 0] = taken_ns
        for answer in self.node.update(stream, message):
            encoded = self.node.encode(answer)
            writing = time.perf_counter_ns()
            for name, data in encoded.items():
                self._write(self.writers[name], data)
            written = time.perf_counter_ns()
            taken = self._taken_ns.pop(answer.stamp_ns, None)
            if taken is not None:
                self._keep_residence(taken, writing, written)
            self.published += 1
            self.last_answer = answer
            self._flag_values[answer.flags] = self._flag_values.get(answer.flags, 0) + 1
        # the network step an answer deferred (network_after_answer), now that it is written
        self._estimator.advance()
        if len(self._taken_ns) > RESIDENCE_KEPT:  # stamps never answered (a repeated stamp)
            self._taken_ns.clear()

    def _keep_residence(self, taken_ns: int, writing_ns: int, written_ns: int) -> None:
        """One answer's residence (module docstring, Residence) and its writes' share, kept
        among the last :data:`RESIDENCE_KEPT`."""
        slot = self._residences % RESIDENCE_KEPT
        self._residence_ns[slot] = written_ns - taken_ns
        self._writes_ns[slot] = written_ns - writing_ns
        self._residences += 1

    def spin_once(self, timeout_s: float = 0.1) -> int:
        """Wait up to ``timeout_s`` for messages and handle all there are; returns how many."""
        from cyclonedds.util import duration
        if self.busy_poll:
            deadline = time.perf_counter() + timeout_s
            while not self._waitset.wait(0) and time.perf_counter() < deadline:
                os.sched_yield()   # the middleware's receive threads may want this core
        else:
            self._waitset.wait(duration(microseconds=int(timeout_s * 1e6)))
        taken_ns = time.perf_counter_ns()
        batch = []
        # the trigger's reader first: the messages published before a HEX10 message arrive
        # before it, so they are in the other readers by the time those are emptied
        for order, stream in enumerate(self._take_order):
            decode = self._decode[stream]
            for data, info in self._take(self.readers[stream], 4096):
                try:
                    message = decode(data)
                except cdr.CdrError as err:  # skipped, not fatal (module docstring)
                    if not self.malformed[stream]:
                        print(f"serve: {self.input_topics.get(stream, stream)}: {err}; such "
                              f"messages are skipped and counted", file=sys.stderr)
                    self.malformed[stream] += 1
                    continue
                batch.append((info.source_timestamp, order, stream, message))
        batch.sort(key=lambda item: item[:2])
        for _, _, stream, message in batch:
            self.received[stream] += 1
            if self.node is None:
                self._held.append((stream, message, taken_ns))
            else:
                self._handle(stream, message, taken_ns)
        if self.node is None:
            self._start()
        return len(batch)

    def _start(self) -> None:
        """Measure the rate once enough HEX10 messages are held, set the estimator to it and
        handle the held messages (module docstring, Rate)."""
        stamps = [stamp_ns(m) or 0 for s, m, _ in self._held if s == "hex10"]
        if len(stamps) < RATE_MESSAGES:
            return
        self._estimator.set_input_rate(stream_rate_hz(stamps, "the HEX10 stream"))
        self.node = self._node()
        held, self._held = self._held, []
        for item in held:
            self._handle(*item)

    def spin(self, duration_s: float | None = None, stop: threading.Event | None = None,
             idle_stop_s: float | None = None, progress_s: float | None = None) -> dict:
        """Handle messages until ``duration_s`` has passed, ``stop`` is set, or nothing came
        for ``idle_stop_s`` after the first message; returns :meth:`report`. ``progress_s``:
        print a line every so often (:meth:`progress`)."""
        end = None if duration_s is None else time.monotonic() + duration_s
        last = None
        watched = shown = started = time.monotonic()
        answered = 0
        while not (stop is not None and stop.is_set()):
            now = time.monotonic()
            if progress_s is not None and now - shown >= progress_s:
                print(self.progress(now - started, (self.published - answered) / (now - shown)),
                      flush=True)
                shown, answered = now, self.published
            if now - watched > 0.5:
                watched = now
                for line in self.watch.check(now):
                    print(line, file=sys.stderr, flush=True)
                    self.warnings.append(line)
            if end is not None and now >= end:
                break
            if self.spin_once(0.05):
                last = now
            elif idle_stop_s is not None and last is not None and now - last > idle_stop_s:
                break
        return self.report()

    def progress(self, elapsed_s: float, answers_per_s: float) -> str:
        """One line for a person watching: the rate of answers and the latest force."""
        answer = self.last_answer
        if answer is None:
            return (f"serve: {elapsed_s:5.1f} s, no answer yet (received "
                    f"{', '.join(f'{s} {n}' for s, n in self.received.items() if s != 'tare')})")
        from psmforce.live.node import status_of
        fx, fy, fz = answer.force_base
        return (f"serve: {elapsed_s:5.1f} s, {answers_per_s:6.0f} answers/s, force on the tool "
                f"(base frame) [{fx:+6.2f} {fy:+6.2f} {fz:+6.2f}] N"
                f"{', ' + status_of(answer.flags)[1] if answer.flags else ''}")

    def flag_counts(self) -> dict[int, int]:
        """Answers that carried each flag bit, by bit number (bits never set left out)."""
        counts: dict[int, int] = {}
        for flags, n in self._flag_values.items():
            for bit in range(flags.bit_length()):
                if flags >> bit & 1:
                    counts[bit] = counts.get(bit, 0) + n
        return dict(sorted(counts.items()))

    def residence_ms(self, part: str = "all") -> dict | None:
        """Median, p99 and max of the residence times kept (module docstring, Residence), ms,
        and how many answers they cover; None before the first answer. ``part="writes"``: the
        same answers' time writing their outputs (the DDS writes, which also hand each sample
        to the transport), the share of the residence no change to the estimator can reduce."""
        n = min(self._residences, RESIDENCE_KEPT)
        if not n:
            return None
        ms = (self._writes_ns if part == "writes" else self._residence_ns)[:n] * 1e-6
        return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
                "max_ms": float(ms.max()), "n": int(n)}

    def report(self) -> dict:
        node = self.node
        out = {"received": dict(self.received), "malformed": dict(self.malformed),
               "answers_published": self.published, "warnings": list(self.warnings),
               "input_topics": self.input_topics, "output_topics": self.output_topics,
               "flag_counts": self.flag_counts(), "residence_ms": self.residence_ms(),
               "residence_writes_ms": self.residence_ms("writes")}
        if node is not None:
            est = node.estimator
            out.update(input_rate_hz=est.input_rate_hz, model_rate_hz=est.rate_hz,
                       decimation=est.decimation, lag_s=est.lag_s(),
                       physics_only_axes=list(est.physics_only_axes),
                       physics_only_prior=("its own" if est.inputs.physics_prior is not None
                                           else "the network's"),
                       tare_offset_N=node.offset.tolist(), unpaired=node.unpaired)
        return out
