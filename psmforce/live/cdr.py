"""The project's CDR encoder for the ROS 2 messages the live node writes and the simulated robot
publishes: the bytes ROS 2 puts on the wire and in a bag, without building message objects.

Encoding: a 4-byte encapsulation header ``00 01 00 00`` (CDR, little-endian), then the fields in
declaration order, each primitive aligned to its own size counted from the end of that header;
a string is its uint32 length including the NUL, its bytes and the NUL; a sequence its uint32
count and its elements. ``tests/test_live_cdr.py`` checks every function here byte for byte
against ``rosbags`` (:data:`psm_model.bags.messages.ROS2_TYPESTORE`) and ``cyclonedds``.

Messages (ROS 2 names; what the node means by them: :mod:`psmforce.live.node`):
``std_msgs/msg/Header`` (inside the others), ``geometry_msgs/msg/WrenchStamped``,
``geometry_msgs/msg/Vector3Stamped``, ``std_msgs/msg/UInt32``, ``std_msgs/msg/Empty``,
``sensor_msgs/msg/JointState``.
"""

from __future__ import annotations

import struct
from typing import Sequence

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


def wrench_stamped(stamp_ns: int, frame_id: str, force: Sequence[float],
                   torque: Sequence[float] = (0.0, 0.0, 0.0)) -> bytes:
    """geometry_msgs/msg/WrenchStamped: stamp (ns since the epoch), frame, force (N), torque
    (Nm)."""
    buf = _Buffer()
    buf.header(stamp_ns, frame_id)
    buf.float64s([float(v) for v in (*force, *torque)])
    return bytes(buf.data)


def vector3_stamped(stamp_ns: int, frame_id: str, vector: Sequence[float]) -> bytes:
    """geometry_msgs/msg/Vector3Stamped."""
    buf = _Buffer()
    buf.header(stamp_ns, frame_id)
    buf.float64s([float(v) for v in vector])
    return bytes(buf.data)


def uint32(value: int) -> bytes:
    """std_msgs/msg/UInt32."""
    buf = _Buffer()
    buf.uint32(int(value))
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
