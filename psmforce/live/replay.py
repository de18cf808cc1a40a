"""``psmforce replay``: a recorded session played through the live node's code path, the
estimates written as a ROS 2 MCAP beside the inputs.

:func:`replay` reads a bag (ROS 2 MCAP / sqlite3 or ROS 1, :mod:`psmforce.io.bags`) in receive
order, hands each arm, jaw and HEX10 message to a :class:`psmforce.live.node.ForceNode` exactly
as ``psmforce serve`` hands it the messages it receives over DDS, and writes one MCAP file
(:class:`psmforce.live.view.McapOut`, profile ``ros2``): every input topic the typestore knows,
copied, and the node's outputs (:func:`psmforce.live.node.output_topics`), each logged at the
receive time of the message it answers. A layout for Foxglove is written beside it
(``OUT.layout.json``, :func:`psmforce.live.view.layout`).

The input rate is the HEX10 stream's, measured from its header stamps (or given); a rate the model
cannot serve is refused in one line before anything is written
(:mod:`psmforce.estimators.data.rates`). ``realtime``: paced by the receive times. ``view_port``:
the same messages served live by a Foxglove WebSocket server on that port while they are played
(:class:`psmforce.live.view.LiveView`: every channel advertised before the first message);
``view_wait_s``: the playback first waits up to that long for a client to subscribe to the estimate
(HEX10 frame), so a viewer that connects after the start still sees it from its first answer.

A message of a stream the node reads whose bytes do not hold its type (a truncated or corrupt
record) is skipped, not copied, and counted per topic (``malformed`` in the report, its reason
printed once per topic), as ``serve`` does: the node goes on with that stream's previous
message, and one bad record never ends the replay.
"""

from __future__ import annotations

import struct
import sys
import time
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError

from psmforce.core.files import atomic_path
from psmforce.estimators.data.rates import RATE_TOLERANCE, RateError, stream_rate_hz
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.networks.uncertainty import predicts_variance
from psmforce.io.bags.messages import ACCEPTED_TYPES, ROS2_TYPESTORE, stamp_ns
from psmforce.io.bags.reading import BagError, resolve_topics
from psmforce.live.node import OUTPUT_TYPES, ForceNode

_RATE_MESSAGES = 2000
"""HEX10 messages whose stamps measure the input rate."""

_UNDECODABLE = (AnyReaderError, ValueError, IndexError, struct.error, UnicodeDecodeError)
"""What decoding raises for bytes that do not hold their message (rosbags wraps most)."""


def _decode(reader: AnyReader, raw, msgtype: str):
    """The message ``raw`` holds, or None when its bytes do not decode (module docstring)."""
    try:
        return reader.deserialize(raw, msgtype)
    except _UNDECODABLE:
        return None


def _open(bag: Path) -> AnyReader:
    try:
        reader = AnyReader([bag], default_typestore=ROS2_TYPESTORE)
        reader.open()
    except Exception as err:  # rosbags raises many types for unreadable input
        raise BagError(f"{bag}: cannot read as a ROS 1 or ROS 2 bag ({type(err).__name__})"
                       ) from None
    return reader


def measure_rate(reader: AnyReader, topic: str) -> float:
    """The HEX10 stream's rate (Hz) from the header stamps of its first messages."""
    connections = [c for c in reader.connections if c.topic == topic]
    stamps = []
    for connection, _, raw in reader.messages(connections=connections):
        message = _decode(reader, raw, connection.msgtype)
        if message is None:
            continue
        stamps.append(stamp_ns(message) or 0)
        if len(stamps) >= _RATE_MESSAGES:
            break
    return stream_rate_hz(stamps, f"topic {topic}")


def replay(bag: str | Path, checkpoint: str | Path, out: str | Path, *, arm: str = "PSM1",
           topics: dict[str, str] | None = None, input_rate_hz: float | None = None,
           post_filter: str = "none", backend: str = "auto", tare_on_start: bool = False,
           tare_s: float = 0.5, sync: bool = False, realtime: bool = False,
           view_port: int | None = None, view_wait_s: float = 0.0,
           view_hold_s: float | None = 0.0, network_after_answer: bool = False) -> dict:
    """Play ``bag`` through the node for ``checkpoint``; write ``out`` (``.mcap``) and its
    layout; return a summary (messages, answers, rate, decimation, flag counts, topics).
    ``topics``: stream -> topic overrides as ``convert`` takes them (js, jaw, hex10, ati).
    ``sync``: pair the streams by stamp (:class:`psmforce.live.node.ForceNode`).
    ``view_wait_s``: with ``view_port``, how long to wait for a client to subscribe to the
    estimate before playing (module docstring); ``view_hold_s``: how long the server stays up
    after the last message (None: until interrupted). ``network_after_answer``: the
    estimator's option (:mod:`psmforce.estimators.runtime.streaming`), as ``serve`` runs it."""
    from psmforce.robot import PSM
    from psmforce.live.view import LiveView, McapOut, write_layout
    bag, out = Path(bag), Path(out)
    if out.suffix != ".mcap":
        raise ValueError(f"--out {out}: must name a .mcap file")
    if out.exists() or out.is_symlink():
        raise ValueError(f"--out {out}: exists already")
    layout_path = out.with_suffix(".layout.json")
    if layout_path.exists() or layout_path.is_symlink():  # no option named it: never replaced
        raise ValueError(f"--out {out}: replay writes {layout_path} beside it, and a file is "
                         f"there already: move it or give another --out")
    resolved, required = resolve_topics(arm, {k: v for k, v in (topics or {}).items()
                                              if k in ("js", "jaw", "hex10", "ati")})
    reader = _open(bag)
    try:
        present = {c.topic: c.msgtype for c in reader.connections}
        for name in ("js", "jaw", "hex10"):
            topic = resolved[name]
            if topic not in present:
                raise BagError(f"{bag}: topic '{topic}' ({name} stream) not in the bag; topics "
                               f"present: {sorted(present)}")
            if present[topic] not in ACCEPTED_TYPES[name]:
                raise BagError(f"{bag}: topic '{topic}' ({name} stream) has type "
                               f"{present[topic]}; expected {' or '.join(ACCEPTED_TYPES[name])}")
        try:
            measured = measure_rate(reader, resolved["hex10"])
        except RateError as err:
            raise BagError(f"{bag}: {err}") from None
        if input_rate_hz is None:
            input_rate_hz = measured
        elif abs(input_rate_hz - measured) > RATE_TOLERANCE * measured:
            raise BagError(f"{bag}: --input-rate {input_rate_hz:g} Hz, but the HEX10 stamps "
                           f"come at {measured:.4g} Hz: give the rate of the stream, or none")
        estimator = StreamingEstimator.from_checkpoint(
            checkpoint, input_rate_hz=input_rate_hz, psm=PSM(), post_filter=post_filter,
            backend=backend, network_after_answer=network_after_answer)
        node = ForceNode(estimator, arm=arm, tare_s=tare_s, sync=sync)
        if tare_on_start:
            node.request_tare()
        stream_of = {resolved[s]: s for s in ("js", "jaw", "hex10")}
        flags = np.zeros(32, np.int64)
        view, viewer = None, None
        try:
            with atomic_path(out) as partial:  # the MCAP exists only once complete
                sink = McapOut(partial)
                try:
                    if view_port is not None:
                        outputs = {node.topics[n]: t for n, t in OUTPUT_TYPES.items()
                                   if n != "std" or predicts_variance(estimator.model)}
                        inputs = {c.topic: c.msgtype for c in reader.connections
                                  if c.msgtype in ROS2_TYPESTORE.types}
                        view = LiveView(view_port, channels=inputs | outputs)
                        viewer = view_wait_s > 0 and view.wait_for_subscriber(
                            node.topics["hex10"], view_wait_s)
                    summary = _play(reader, node, stream_of, sink, view, realtime, flags)
                finally:
                    sink.close()
            layout = write_layout(layout_path, node.topics["hex10"],
                                  resolved["hex10"], resolved.get("ati")
                                  if resolved.get("ati") in present else None)
            if view is not None:
                view.hold(view_hold_s)  # the files are complete: an interrupt loses nothing
        finally:
            if view is not None:
                view.close()
    finally:
        reader.close()
    return {"bag": str(bag), "out": str(out), "layout": str(layout),
            "input_rate_hz": estimator.input_rate_hz, "model_rate_hz": estimator.rate_hz,
            "decimation": estimator.decimation, "lag_s": estimator.lag_s(),
            "answers": node.answers, "unpaired": node.unpaired,
            "tare_offset_N": node.offset.tolist(),
            "flag_counts": {bit: int(n) for bit, n in enumerate(flags) if n},
            "topics": dict(sorted(sink.counts.items())),
            **({"view_port": view.port, "viewer_before_play": viewer} if view else {}), **summary}


def _play(reader, node: ForceNode, stream_of: dict, sink, view, realtime: bool,
          flags: np.ndarray) -> dict:
    start_wall = start_log = None
    last_ns = 0
    copied = skipped = 0
    malformed: dict[str, int] = {}
    for connection, log_ns, raw in reader.messages():
        if realtime:
            if start_wall is None:
                start_wall, start_log = time.monotonic(), log_ns
            delay = start_wall + (log_ns - start_log) * 1e-9 - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        msgtype, topic = connection.msgtype, connection.topic
        if msgtype not in ROS2_TYPESTORE.types:
            skipped += 1
            continue
        stream = stream_of.get(topic)
        message = None
        if stream is not None or not reader.is2:
            message = _decode(reader, raw, msgtype)
            if message is None:  # skipped and counted, as serve does (module docstring)
                if topic not in malformed:
                    print(f"replay: {topic}: a message whose bytes do not hold a {msgtype}; "
                          f"such messages are skipped and counted", file=sys.stderr)
                malformed[topic] = malformed.get(topic, 0) + 1
                continue
        if not reader.is2:  # ROS 1: re-serialised as ROS 2 CDR
            raw = ROS2_TYPESTORE.serialize_cdr(message, msgtype)
        _emit(sink, view, topic, msgtype, bytes(raw), log_ns)
        copied += 1
        if stream is None:
            continue
        _answer(node, node.update(stream, message), sink, view, log_ns, flags)
        last_ns = log_ns
    _answer(node, node.flush(), sink, view, last_ns, flags)
    return {"inputs_copied": copied, "inputs_skipped": skipped, "malformed": malformed}


def _answer(node: ForceNode, answers, sink, view, log_ns: int, flags: np.ndarray) -> None:
    for answer in answers:
        for name, data in node.encode(answer).items():
            _emit(sink, view, node.topics[name], OUTPUT_TYPES[name], data, log_ns)
        flags += (answer.flags >> np.arange(32)) & 1


def _emit(sink, view, topic: str, msgtype: str, data: bytes, log_ns: int) -> None:
    sink.write(topic, msgtype, data, log_ns)
    if view is not None:
        view.write(topic, msgtype, data, log_ns)
