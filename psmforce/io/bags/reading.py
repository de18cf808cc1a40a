"""Reading the dVRK streams out of a bag: one table of (time stamp, values) per stream.

Streams (name: default topic, message type -> recording columns):

* ``js``: ``/{arm}/measured_js``, sensor_msgs/JointState -> ``{joint}_position``, ``_velocity``,
  ``_effort`` for the six chain joints;
* ``jaw``: ``/{arm}/jaw/measured_js``, sensor_msgs/JointState -> ``jaw_position``, ``_velocity``,
  ``_effort``;
* ``hex10``: ``/hex10/measured_cf``, geometry_msgs/WrenchStamped (or Wrench) -> ``fx .. tz``;
* ``ati``: ``/ati/measured_cf``, geometry_msgs/WrenchStamped (or Wrench) -> ``ati_raw_fx .. _tz``;
* ``jacobian``: ``/{arm}/spatial/jacobian``, std_msgs/Float64MultiArray (6x6) ->
  ``spatial_jacobian_{r}{c}`` (row r, column c, as published).

``js``, ``jaw`` and ``hex10`` are required. ``ati`` and ``jacobian`` are optional: under their
default topic they are skipped (and the report says so) when the bag lacks them; a topic the caller
names explicitly must exist.

Joints are matched by NAME, never by position in the message: the dVRK >= 2024 names
(:data:`psmforce.io.recording.JOINTS`) and the older ``outer_*`` names (``outer_yaw``,
``outer_pitch``, ``outer_insertion``, ``outer_roll``, ``outer_wrist_pitch``, ``outer_wrist_yaw``).
A ``jaw`` entry in the arm topic (dVRK 1.x published seven joints there) is ignored: the jaw comes
from the jaw topic. Any other name is an error. Values are taken as the dVRK publishes them (rad,
rad/s, Nm; m, m/s, N for the insertion; N and Nm for wrenches). The decoding is
:mod:`.messages`', shared with ``replay`` and ``serve``.

Time of a message: its header stamp. A stream whose messages carry no header (Float64MultiArray,
Wrench) or where any header stamp is zero uses the bag's receive time for ALL its messages, so
one stream never mixes two clocks; the report names the source per stream.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader

from psmforce.io.bags.messages import (ACCEPTED_TYPES, JACOBIAN_COLUMNS, JOINT_STATE,  # noqa: F401
                                     MULTI_ARRAY, ROS2_TYPESTORE, STREAMS, WRENCH,
                                     WRENCH_STAMPED, JointStateDecoder, MessageError,
                                     jacobian_values, stamp_ns, stream_columns, wrench_values)
from psmforce.io.bags.names import check_namespace, check_ros_name
from psmforce.io.recording import RecordingError

REQUIRED_STREAMS = ("js", "jaw", "hex10")


class BagError(RecordingError):
    """A bag that cannot be converted; the message names the bag and the problem."""


@dataclass(frozen=True)
class RawStream:
    """One stream as read, in bag order (unsorted, duplicates kept)."""

    name: str
    topic: str
    msgtype: str
    stamps_ns: np.ndarray
    """(N,) int64 time of each message, ns (header stamp or bag time, see ``time_source``)."""
    values: np.ndarray
    """(N, len(columns)) float64."""
    columns: tuple[str, ...]
    time_source: str
    """``"header"`` or ``"bag"``."""
    zero_header_stamps: int


def default_topics(arm: str = "PSM1") -> dict[str, str]:
    """The dVRK 2.x (CRTK) topic of each stream for arm namespace ``arm``."""
    return {"js": f"/{arm}/measured_js", "jaw": f"/{arm}/jaw/measured_js",
            "hex10": "/hex10/measured_cf", "ati": "/ati/measured_cf",
            "jacobian": f"/{arm}/spatial/jacobian"}


def resolve_topics(arm: str, topics: dict[str, str | None] | None
                   ) -> tuple[dict[str, str], set[str]]:
    """Topic per stream after the caller's overrides, and the streams that must be present.

    ``topics`` maps stream names (:data:`STREAMS`) to topic names; ``None`` switches an optional
    stream off.
    """
    try:
        arm = check_namespace(arm)
    except ValueError as err:
        raise BagError(str(err)) from None
    resolved = default_topics(arm)
    required = set(REQUIRED_STREAMS)
    overrides = dict(topics or {})
    unknown = sorted(set(overrides) - set(STREAMS))
    if unknown:
        raise BagError(f"unknown stream names in topics: {unknown}; known: {list(STREAMS)}")
    for name, topic in overrides.items():
        if topic is None:
            if name in REQUIRED_STREAMS:
                raise BagError(f"stream '{name}' is required and cannot be switched off")
            del resolved[name]
            continue
        try:
            resolved[name] = check_ros_name(topic, f"topic for stream '{name}'")
        except ValueError as err:
            raise BagError(str(err)) from None
        required.add(name)
    by_topic: dict[str, list[str]] = {}
    for name, topic in resolved.items():
        by_topic.setdefault(topic, []).append(name)
    shared = {t: n for t, n in by_topic.items() if len(n) > 1}
    if shared:
        raise BagError(f"one topic serves several streams: {shared}")
    return resolved, required


def read_streams(bag_path: Path, topics: dict[str, str], required: set[str]
                 ) -> tuple[dict[str, RawStream], dict[str, str], str]:
    """Read the streams named in ``topics`` from the bag.

    Returns the streams read, the optional streams skipped (name -> reason) and the bag kind
    (``"ROS 2"`` or ``"ROS 1"``). Raises :class:`BagError` for an unreadable or empty bag, a missing
    required topic, a wrong message type or bad message content.
    """
    if bag_path.is_dir() and not (bag_path / "metadata.yaml").exists():
        raise BagError(f"{bag_path}: cannot read as a ROS 1 or ROS 2 bag (a folder without "
                       f"metadata.yaml; pass a ROS 2 bag folder or its .mcap / .db3 file)")
    try:
        reader = AnyReader([bag_path], default_typestore=ROS2_TYPESTORE)
        reader.open()
    except Exception as err:  # rosbags raises many types for corrupt input; all mean "unreadable"
        raise _unreadable(bag_path, err) from None
    try:
        kind = "ROS 2" if reader.is2 else "ROS 1"
        present = {name: info.msgtype for name, info in reader.topics.items()}
        counts = {name: info.msgcount for name, info in reader.topics.items()}
        if not present or sum(counts.values()) == 0:
            raise BagError(f"{bag_path}: the bag is empty (no messages on any topic)")
        collectors: dict[str, _Collector] = {}
        skipped: dict[str, str] = {}
        for name, topic in topics.items():
            if topic not in present or counts[topic] == 0:
                problem = "not in the bag" if topic not in present else "has no messages"
                if name not in required:
                    skipped[name] = f"{topic} {problem}"
                    continue
                raise BagError(f"{bag_path}: topic '{topic}' ({name} stream) {problem}; "
                               f"topics present: {sorted(present)}")
            msgtype = present[topic]
            if msgtype not in ACCEPTED_TYPES[name]:
                raise BagError(f"{bag_path}: topic '{topic}' ({name} stream) has type {msgtype}; "
                               f"expected {' or '.join(ACCEPTED_TYPES[name])}")
            collectors[topic] = _Collector(name, topic, msgtype, bag_path)
        connections = [c for c in reader.connections if c.topic in collectors]
        messages = reader.messages(connections=connections)
        while True:
            try:
                item = next(messages, None)
                if item is None:
                    break
                connection, log_ns, raw = item
                message = reader.deserialize(raw, connection.msgtype)
            except Exception as err:  # corrupt chunk or payload deep in rosbags
                raise _unreadable(bag_path, err) from None
            collectors[connection.topic].add(message, log_ns)
    finally:
        try:
            reader.close()
        except Exception:  # closing a half-broken file must not hide the first error
            pass
    streams = {c.name: c.finish() for c in collectors.values()}
    return streams, skipped, kind


def _unreadable(bag_path: Path, err: Exception) -> BagError:
    detail = str(err).strip().splitlines()[0] if str(err).strip() else ""
    return BagError(f"{bag_path}: cannot read as a ROS 1 or ROS 2 bag "
                    f"({type(err).__name__}{': ' + detail if detail else ''})")


class _Collector:
    """Accumulates one topic's messages as plain numbers while the bag is read."""

    def __init__(self, name: str, topic: str, msgtype: str, bag_path: Path):
        self.name, self.topic, self.msgtype, self.bag_path = name, topic, msgtype, bag_path
        self.header_ns: list[int] = []
        self.log_ns: list[int] = []
        self.rows: list[np.ndarray] = []
        self.columns = stream_columns(name)
        if msgtype == JOINT_STATE:
            self._decode = JointStateDecoder(name)
        elif msgtype in (WRENCH_STAMPED, WRENCH):
            self._decode = wrench_values
        else:
            self._decode = jacobian_values

    def _fail(self, problem: str) -> BagError:
        return BagError(f"{self.bag_path}: topic '{self.topic}' message {len(self.log_ns)}: "
                        f"{problem}")

    def add(self, message, log_ns: int) -> None:
        stamp = stamp_ns(message)
        if stamp is not None:
            self.header_ns.append(stamp)
        try:
            self.rows.append(self._decode(message))
        except MessageError as err:
            raise self._fail(str(err)) from None
        self.log_ns.append(int(log_ns))

    def finish(self) -> RawStream:
        values = np.vstack(self.rows)
        bad = np.argwhere(~np.isfinite(values))
        if len(bad):
            row, col = bad[0]
            raise BagError(f"{self.bag_path}: topic '{self.topic}' message {row}: non-finite value "
                           f"in {self.columns[col]}")
        header = np.array(self.header_ns, dtype=np.int64)
        zero = int(np.count_nonzero(header == 0)) if len(header) else 0
        use_header = len(header) == len(self.log_ns) and zero == 0
        stamps = header if use_header else np.array(self.log_ns, dtype=np.int64)
        return RawStream(self.name, self.topic, self.msgtype, stamps, values, self.columns,
                         "header" if use_header else "bag", zero)
