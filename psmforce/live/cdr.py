"""The project's CDR encoder for the ROS 2 messages the live node writes and the simulated robot
publishes, and decoder for those it reads: the bytes ROS 2 puts on the wire and in a bag, without
the middleware's Python message classes, which take longer to decode (``benchmarks/live.py``
times both).

Encoding: a 4-byte encapsulation header ``00 01 00 00`` (CDR, little-endian), then the fields in
declaration order, each primitive aligned to its own size counted from the end of that header;
a string is its uint32 length including the NUL, its bytes and the NUL; a sequence its uint32
count and its elements. ``tests/live/test_live_cdr.py`` checks every function here byte for byte
against ``rosbags`` (:data:`psmforce.io.bags.messages.ROS2_TYPESTORE`) and ``cyclonedds``.

Decoding (:func:`decode_joint_state`, :func:`decode_wrench_stamped`; per stream, :class:`Stream`,
which decodes a stream's frame and joint names once) reads either byte order
(encapsulation ``00 01``, little-endian, or ``00 00``, big-endian: plain CDR, what ROS 2's
middlewares write) into light messages with the ROS 2 field names (``msg.name``,
``msg.header.stamp.sec``, ``msg.wrench.force.x``; a JointState's arrays are float64 numpy
views of the bytes), which :mod:`psmforce.io.bags.messages` decodes like any other. Bytes that do
not hold the message (cut short, a length past the end, another encapsulation, a string without
its NUL or not UTF-8) raise :class:`CdrError` naming what is wrong. Bytes after the message
(padding to four bytes, or an appended field) are ignored, as the middlewares' readers do.

Messages (ROS 2 names; what the node means by them: :mod:`psmforce.live.node`):
``std_msgs/msg/Header`` (inside the others), ``geometry_msgs/msg/WrenchStamped``,
``geometry_msgs/msg/Vector3Stamped``, ``std_msgs/msg/UInt32``, ``std_msgs/msg/Empty``,
``sensor_msgs/msg/JointState``, ``diagnostic_msgs/msg/DiagnosticArray``.
"""

from __future__ import annotations

import functools
import struct
from typing import NamedTuple, Sequence

import numpy as np

_HEADER = b"\x00\x01\x00\x00"


class _Buffer:
    def __init__(self):
        self.data = bytearray(_HEADER)

    def align(self, size: int) -> None:
        self.data += b"\x00" * (-(len(self.data) - 4) % size)

    def uint32(self, value: int) -> None:
        self.align(4)
        self.data += struct.pack("<I", value)

    def float64s(self, values: Sequence[float]) -> None:
        self.align(8)
        self.data += struct.pack(f"<{len(values)}d", *values)

    def string(self, text: str) -> None:
        raw = text.encode() + b"\x00"
        self.uint32(len(raw))
        self.data += raw

    def header(self, stamp_ns: int, frame_id: str) -> None:
        sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
        self.align(4)
        self.data += struct.pack("<iI", sec, nanosec)
        self.string(frame_id)


@functools.lru_cache(maxsize=64)
def _header_and_float64s(frame_id: str, n: int) -> tuple[struct.Struct, bytes]:
    """The layout of a message that is a header then ``n`` float64s (the encapsulation, stamp,
    frame string, padding to 8, the values) as one struct, and the frame's string bytes: one
    ``pack`` per message, as the node writes several each millisecond."""
    raw = frame_id.encode() + b"\x00"
    pad = -(12 + len(raw)) % 8
    return struct.Struct(f"<4siII{len(raw)}s{pad}x{n}d"), raw


def _stamped_float64s(stamp_ns: int, frame_id: str, values: Sequence[float]) -> bytes:
    layout, raw = _header_and_float64s(frame_id, len(values))
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return layout.pack(_HEADER, sec, nanosec, len(raw), raw, *values)


def wrench_stamped(stamp_ns: int, frame_id: str, force: Sequence[float],
                   torque: Sequence[float] = (0.0, 0.0, 0.0)) -> bytes:
    """geometry_msgs/msg/WrenchStamped: stamp (ns since the epoch), frame, force (N), torque
    (Nm)."""
    return _stamped_float64s(stamp_ns, frame_id, [float(v) for v in (*force, *torque)])


def vector3_stamped(stamp_ns: int, frame_id: str, vector: Sequence[float]) -> bytes:
    """geometry_msgs/msg/Vector3Stamped."""
    return _stamped_float64s(stamp_ns, frame_id, [float(v) for v in vector])


def uint32(value: int) -> bytes:
    """std_msgs/msg/UInt32."""
    return _HEADER + struct.pack("<I", int(value))


_STAMP = struct.Struct("<iI")


def restamp(data: bytes, stamp_ns: int) -> bytearray:
    """A stamped message's bytes (a Header first) with the stamp replaced: the stamp is the
    first 8 bytes after the encapsulation, whatever follows."""
    out = bytearray(data)
    _STAMP.pack_into(out, 4, *divmod(int(stamp_ns), 1_000_000_000))
    return out


def string_tail(text: str) -> bytes:
    """A string's bytes (length, text, NUL), to append where a string's length field starts (4
    bytes aligned after the encapsulation, any padding before it already in place): a message
    that ends in a string is its bytes up to that field plus these."""
    raw = text.encode() + b"\x00"
    return struct.pack("<I", len(raw)) + raw


def diagnostic_array(stamp_ns: int, frame_id: str,
                     statuses: Sequence[tuple[int, str, str, str, Sequence[tuple[str, str]]]]
                     ) -> bytes:
    """diagnostic_msgs/msg/DiagnosticArray: a header and, per status, ``(level, name,
    message, hardware_id, [(key, value), ...])`` (level: 0 OK, 1 WARN, 2 ERROR, 3 STALE)."""
    buf = _Buffer()
    buf.header(stamp_ns, frame_id)
    buf.uint32(len(statuses))
    for level, name, message, hardware_id, values in statuses:
        buf.data += bytes((int(level),))  # a byte: no alignment
        for text in (name, message, hardware_id):
            buf.string(text)
        buf.uint32(len(values))
        for key, value in values:
            buf.string(key)
            buf.string(value)
    return bytes(buf.data)


def empty() -> bytes:
    """std_msgs/msg/Empty (one padding byte, as ROS 2's IDL gives an empty structure)."""
    return _HEADER + b"\x00"


def joint_state(stamp_ns: int, frame_id: str, names: Sequence[str], position: Sequence[float],
                velocity: Sequence[float], effort: Sequence[float]) -> bytes:
    """sensor_msgs/msg/JointState."""
    buf = _Buffer()
    buf.header(stamp_ns, frame_id)
    buf.uint32(len(names))
    for name in names:
        buf.string(name)
    for values in (position, velocity, effort):
        buf.uint32(len(values))
        if len(values):
            buf.float64s([float(v) for v in values])
    return bytes(buf.data)


# ------------------------------------------------------------------------------ decoding

class CdrError(ValueError):
    """Bytes that do not hold the message asked for; the text says why."""


class Time(NamedTuple):
    sec: int
    nanosec: int


class Header(NamedTuple):
    stamp: Time
    frame_id: str


class Vector3(NamedTuple):
    x: float
    y: float
    z: float


class Wrench(NamedTuple):
    force: Vector3
    torque: Vector3


class WrenchStamped(NamedTuple):
    """geometry_msgs/msg/WrenchStamped as decoded (N, Nm)."""
    header: Header
    wrench: Wrench


class JointState(NamedTuple):
    """sensor_msgs/msg/JointState as decoded (arrays: float64, read-only views of the bytes)."""
    header: Header
    name: tuple[str, ...]
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray


class _Reader:
    """A cursor over CDR bytes; every read checks it stays inside them."""

    def __init__(self, data: bytes, what: str):
        self.data, self.what = memoryview(data), what
        if len(data) < 4:
            raise CdrError(f"{what}: {len(data)} bytes, fewer than the 4 of the encapsulation")
        kind = bytes(self.data[:2])
        if kind not in (b"\x00\x01", b"\x00\x00"):
            raise CdrError(f"{what}: encapsulation {kind.hex()} is not plain CDR (0001 little-"
                           f"endian or 0000 big-endian)")
        self.order = "<" if kind == b"\x00\x01" else ">"
        self.pos = 4

    def take(self, size: int, align: int) -> int:
        """Align to ``align`` (counted from the end of the encapsulation), then claim ``size``
        bytes; returns where they start."""
        start = self.pos + (-(self.pos - 4) % align)
        if start + size > len(self.data):
            raise CdrError(f"{self.what}: needs {start + size} bytes, has {len(self.data)} "
                           f"(cut short, or another message type)")
        self.pos = start + size
        return start

    def unpack(self, fmt: str, size: int, align: int) -> tuple:
        return struct.unpack_from(self.order + fmt, self.data, self.take(size, align))

    def count(self, element_size: int) -> int:
        """A sequence's length, refused where its elements could not fit in what is left."""
        (n,) = self.unpack("I", 4, 4)
        if n * element_size > len(self.data) - self.pos:
            raise CdrError(f"{self.what}: a length of {n} runs past the end of the "
                           f"{len(self.data)} bytes")
        return n

    def string(self) -> str:
        return self.strings(1)[0]

    def strings(self, n: int) -> tuple[str, ...]:
        """``n`` strings; one loop without the helpers' calls, as a JointState's names are
        decoded on every message."""
        data, pos, end, length = self.data, self.pos, len(self.data), self.order + "I"
        out = []
        for _ in range(n):
            pos += -(pos - 4) % 4
            if pos + 4 > end:
                raise CdrError(f"{self.what}: cut short inside a string's length")
            (k,) = struct.unpack_from(length, data, pos)
            pos += 4
            if pos + k > end:
                raise CdrError(f"{self.what}: a string of {k} bytes runs past the end of the "
                               f"{end} bytes")
            if k == 0 or data[pos + k - 1] != 0:
                raise CdrError(f"{self.what}: a string without its terminating NUL")
            try:
                out.append(str(data[pos:pos + k - 1], "utf-8"))
            except UnicodeDecodeError:
                raise CdrError(f"{self.what}: a string that is not UTF-8") from None
            pos += k
        self.pos = pos
        return tuple(out)

    def header(self) -> Header:
        sec, nanosec = self.unpack("iI", 8, 4)
        return Header(Time(sec, nanosec), self.string())

    def float64s(self, n: int) -> np.ndarray:
        if n == 0:  # an empty sequence has no element to align
            return np.empty(0)
        start = self.take(8 * n, 8)
        return np.frombuffer(self.data, np.dtype(self.order + "f8"), n, start)


def decode_wrench_stamped(data: bytes) -> WrenchStamped:
    """geometry_msgs/msg/WrenchStamped from its CDR bytes (module docstring)."""
    r = _Reader(data, "WrenchStamped")
    header = r.header()
    v = r.unpack("6d", 48, 8)
    return WrenchStamped(header, Wrench(Vector3(*v[:3]), Vector3(*v[3:])))


def decode_joint_state(data: bytes) -> JointState:
    """sensor_msgs/msg/JointState from its CDR bytes (module docstring). The arrays' lengths are
    read as sent: whether they match the names is the stream decoder's check
    (:class:`psmforce.io.bags.messages.JointStateDecoder`)."""
    r = _Reader(data, "JointState")
    header = r.header()
    names = r.strings(r.count(5))  # a string: its length and its NUL at least
    arrays = [r.float64s(r.count(8)) for _ in range(3)]
    return JointState(header, names, *arrays)


class _Layout(NamedTuple):
    """What a stream's last fully decoded message fixes for the next ones (:class:`Stream`)."""
    size: int
    head: bytes
    """Bytes 12 up to the first field after the names (frame, names): compared every message."""
    encapsulation: bytes
    order: str
    counts: tuple[tuple[int, int], ...]
    """(offset, value) of each array's length (JointState)."""
    arrays: tuple[tuple[int, int], ...]
    """(offset, length) of each float64 array."""
    frame_id: str
    names: tuple[str, ...]


class Stream:
    """:func:`decode_joint_state` (``kind="JointState"``) or :func:`decode_wrench_stamped`
    (``"WrenchStamped"``) for the messages of one stream, which carry the same frame and joint
    names message after message: those, and so where every value sits, are decoded once and
    then compared with each message's bytes (its size, encapsulation, frame, names and array
    lengths), so a matching message costs its stamp and its values alone; any other is decoded in
    full (same messages, same :class:`CdrError`) and becomes the layout compared next."""

    def __init__(self, kind: str):
        if kind not in ("JointState", "WrenchStamped"):
            raise ValueError(f"a stream decodes JointState or WrenchStamped, not {kind!r}")
        self.kind = kind
        self._layout: _Layout | None = None
        self._full = decode_joint_state if kind == "JointState" else decode_wrench_stamped

    def __call__(self, data: bytes):
        layout = self._layout
        if layout is None or len(data) != layout.size \
                or not data.startswith(layout.encapsulation) \
                or not data.startswith(layout.head, 12) \
                or any(_UINT32[layout.order].unpack_from(data, at)[0] != n
                       for at, n in layout.counts):
            message = self._full(data)
            self._layout = self._learn(data, message)
            return message
        sec, nanosec = _STAMP_OF[layout.order].unpack_from(data, 4)
        header = Header(Time(sec, nanosec), layout.frame_id)
        if self.kind == "WrenchStamped":
            (at, _), = layout.arrays
            v = _SIX[layout.order].unpack_from(data, at)
            return WrenchStamped(header, Wrench(Vector3(*v[:3]), Vector3(*v[3:])))
        dtype = _FLOAT64[layout.order]
        return JointState(header, layout.names,
                          *[np.frombuffer(data, dtype, n, at) if n else np.empty(0)
                            for at, n in layout.arrays])

    def _learn(self, data: bytes, message) -> _Layout:
        """The layout of ``message``, just decoded in full from ``data``: the offsets the
        full decoder's cursor reached, walked again."""
        r = _Reader(data, self.kind)
        r.header()
        counts, arrays = [], []
        if self.kind == "JointState":
            r.strings(r.count(5))
            head_end = r.pos
            for _ in range(3):
                n = r.count(8)
                counts.append((r.pos - 4, n))
                arrays.append((r.take(8 * n, 8) if n else r.pos, n))
        else:
            head_end = r.pos
            arrays.append((r.take(48, 8), 6))
        return _Layout(len(data), bytes(data[12:head_end]), bytes(data[:4]), r.order,
                       tuple(counts), tuple(arrays), message.header.frame_id,
                       getattr(message, "name", ()))


_UINT32 = {o: struct.Struct(o + "I") for o in "<>"}
_STAMP_OF = {o: struct.Struct(o + "iI") for o in "<>"}
_SIX = {o: struct.Struct(o + "6d") for o in "<>"}
_FLOAT64 = {o: np.dtype(o + "f8") for o in "<>"}
