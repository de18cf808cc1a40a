"""CDR bytes of every message type the live node uses: the project's encoder
(psmforce.live.cdr), cyclonedds (psmforce.live.dds) and rosbags give the same bytes."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.io.bags.messages import ROS2_TYPESTORE
from psmforce.live import cdr

pytest.importorskip("cyclonedds")
from psmforce.live import dds  # noqa: E402

STAMP = 1_700_000_123_456_789_012
T = ROS2_TYPESTORE.types


def _ros_header(frame_id):
    sec, nanosec = divmod(STAMP, 10**9)
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec,
                                                                           nanosec=nanosec),
                                    frame_id=frame_id)


def _vector(values):
    return T["geometry_msgs/msg/Vector3"](x=values[0], y=values[1], z=values[2])


def _cases():
    rng = np.random.default_rng(0)
    force, torque, std = rng.normal(size=3), rng.normal(size=3), rng.uniform(size=3)
    names = ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"]
    q, dq, tau = rng.normal(size=6), rng.normal(size=6), rng.normal(size=6)
    wrench = T["geometry_msgs/msg/Wrench"](force=_vector(force), torque=_vector(torque))
    yield ("geometry_msgs/msg/WrenchStamped",
           cdr.wrench_stamped(STAMP, "PSM1_base", force, torque),
           dds.WrenchStamped(dds.header(STAMP, "PSM1_base"),
                             dds.Wrench(dds.Vector3(*force), dds.Vector3(*torque))),
           T["geometry_msgs/msg/WrenchStamped"](header=_ros_header("PSM1_base"), wrench=wrench))
    for frame_id in ("", "hex10", "a_frame_of_any_length"):  # every padding before the values
        yield ("geometry_msgs/msg/WrenchStamped",
               cdr.wrench_stamped(STAMP, frame_id, force),
               dds.WrenchStamped(dds.header(STAMP, frame_id),
                                 dds.Wrench(dds.Vector3(*force), dds.Vector3(0.0, 0.0, 0.0))),
               T["geometry_msgs/msg/WrenchStamped"](
                   header=_ros_header(frame_id), wrench=T["geometry_msgs/msg/Wrench"](
                       force=_vector(force), torque=_vector((0.0, 0.0, 0.0)))))
    yield ("geometry_msgs/msg/Vector3Stamped", cdr.vector3_stamped(STAMP, "hex10", std),
           dds.Vector3Stamped(dds.header(STAMP, "hex10"), dds.Vector3(*std)),
           T["geometry_msgs/msg/Vector3Stamped"](header=_ros_header("hex10"),
                                                 vector=_vector(std)))
    yield ("std_msgs/msg/UInt32", cdr.uint32(2**16 + 33), dds.UInt32(2**16 + 33),
           T["std_msgs/msg/UInt32"](data=2**16 + 33))
    yield ("std_msgs/msg/Empty", cdr.empty(), dds.Empty(),
           T["std_msgs/msg/Empty"]())
    for n in (6, 1, 0):  # the arm, the jaw, an empty message (the lengths change the padding)
        yield ("sensor_msgs/msg/JointState",
               cdr.joint_state(STAMP, "", names[:n], q[:n], dq[:n], tau[:n]),
               dds.JointState(dds.header(STAMP, ""), names[:n], list(q[:n]), list(dq[:n]),
                              list(tau[:n])),
               T["sensor_msgs/msg/JointState"](header=_ros_header(""), name=names[:n],
                                               position=q[:n], velocity=dq[:n],
                                               effort=tau[:n]))


@pytest.mark.parametrize("case", list(_cases()), ids=lambda c: c[0].split("/")[-1])
def test_project_cyclonedds_and_rosbags_bytes_are_identical(case):
    msgtype, ours, theirs_dds, theirs_rosbags = case
    rosbags_bytes = bytes(ROS2_TYPESTORE.serialize_cdr(theirs_rosbags, msgtype))
    assert ours == rosbags_bytes
    assert ours == theirs_dds.serialize()
    assert type(theirs_dds).deserialize(ours) == theirs_dds


def test_ros2_names_map_onto_dds_names():
    assert dds.dds_topic("/PSM1/measured_js") == "rt/PSM1/measured_js"
    assert dds.dds_type_name("sensor_msgs/msg/JointState") == "sensor_msgs::msg::dds_::JointState_"
    assert dds.JointState.__idl_typename__ == "sensor_msgs::msg::dds_::JointState_"
    assert set(dds.TYPES) <= set(ROS2_TYPESTORE.types)


def _fields(msg):
    """A decoded message's fields as plain Python (either decoder's classes)."""
    if hasattr(msg, "wrench"):
        f, t = msg.wrench.force, msg.wrench.torque
        values = [f.x, f.y, f.z, t.x, t.y, t.z]
        return msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id, values
    return (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id, list(msg.name),
            *(np.asarray(getattr(msg, k), float).tolist() for k in ("position", "velocity",
                                                                    "effort")))


DECODERS = {"geometry_msgs/msg/WrenchStamped": cdr.decode_wrench_stamped,
            "sensor_msgs/msg/JointState": cdr.decode_joint_state}
DECODED = [c for c in _cases() if c[0] in DECODERS]


@pytest.mark.parametrize("case", DECODED, ids=lambda c: f"{c[0].split('/')[-1]}{len(c[1])}")
def test_decoding_gives_what_rosbags_gives_in_either_byte_order(case):
    msgtype, ours, _, theirs = case
    decode = DECODERS[msgtype]
    assert _fields(decode(ours)) == _fields(ROS2_TYPESTORE.deserialize_cdr(ours, msgtype))
    big = bytes(ROS2_TYPESTORE.serialize_cdr(theirs, msgtype, little_endian=False))
    assert big[:2] == b"\x00\x00" and big != ours
    assert _fields(decode(big)) == _fields(theirs)
    assert _fields(decode(ours + b"\x00" * 7)) == _fields(theirs)  # padding after: ignored


@pytest.mark.parametrize("case", DECODED, ids=lambda c: f"{c[0].split('/')[-1]}{len(c[1])}")
def test_bytes_that_do_not_hold_the_message_raise_cdr_error_naming_why(case):
    msgtype, ours, _, _ = case
    decode = DECODERS[msgtype]
    for n in range(len(ours)):  # every cut: the last field is needed whole
        with pytest.raises(cdr.CdrError, match="bytes|encapsulation|string"):
            decode(ours[:n])
    with pytest.raises(cdr.CdrError, match="encapsulation 0007"):
        decode(b"\x00\x07" + ours[2:])
    # the frame id's length (after the 8-byte stamp) past the end; then its NUL overwritten
    with pytest.raises(cdr.CdrError, match="runs past the end"):
        decode(ours[:12] + b"\xff\xff\xff\x7f" + ours[16:])
    nul = 16 + len(_fields(decode(ours))[2])  # the frame id's NUL
    with pytest.raises(cdr.CdrError, match="NUL"):
        decode(ours[:nul] + b"!" + ours[nul + 1:])
    rng = np.random.default_rng(0)  # any bytes: a message or a CdrError, nothing else
    for _ in range(300):
        noisy = bytearray(ours)
        at = rng.integers(4, len(noisy), size=3)
        noisy[at[0]] ^= 0xFF
        noisy[at[1]] = int(rng.integers(256))
        try:
            decode(bytes(noisy)[:int(at[2]) + 1 if rng.random() < 0.3 else None])
        except cdr.CdrError:
            pass


def _outcome(decode, data):
    """What ``decode`` makes of ``data``: the message's fields, or the CdrError's text."""
    try:
        return _fields(decode(data))
    except cdr.CdrError as err:
        return f"CdrError: {err}"


@pytest.mark.parametrize("kind", ["JointState", "WrenchStamped"])
def test_a_stream_decodes_every_message_as_the_full_decoder_does(kind):
    """Repeats (its layout kept), new stamps and values, another frame, names or byte order,
    array lengths that change while the size does not, cuts and noise: message after message,
    the stream's answer is the full decoder's, errors included."""
    msgtype = next(t for t in DECODERS if t.endswith(kind))
    full, stream = DECODERS[msgtype], cdr.Stream(kind)
    rng = np.random.default_rng(1)
    sequence = []
    for _, ours, _, theirs in (c for c in DECODED if c[0] == msgtype):
        big = bytes(ROS2_TYPESTORE.serialize_cdr(theirs, msgtype, little_endian=False))
        for data in (ours, ours, big, big, ours + b"\x00" * 4, ours):
            sequence += [data, data[:4] + rng.bytes(8) + data[12:], data[:-8] + rng.bytes(8)]
        for _ in range(40):
            noisy = bytearray(ours)
            noisy[int(rng.integers(4, len(ours)))] ^= int(rng.integers(1, 256))
            sequence += [ours, bytes(noisy)[:None if rng.random() < 0.7 else -3]]
    if kind == "JointState":  # the same size, names and frame; other array lengths
        names = ["a", "b", "c", "d", "e", "f"]
        same_size = [cdr.joint_state(STAMP, "", names, [1.0] * 6, [2.0] * 6, [3.0] * 6),
                     cdr.joint_state(STAMP, "", names, [1.0] * 6, [], [3.0] * 13),
                     cdr.joint_state(STAMP, "", names, [1.0] * 7, [2.0] * 5, [3.0] * 6)]
        assert len({len(d) for d in same_size}) == 1
        sequence += same_size + same_size[::-1]
    answers = [(_outcome(stream, d), _outcome(full, d)) for d in sequence]
    assert all(ours == theirs for ours, theirs in answers)
    assert sum(isinstance(ours, str) for ours, _ in answers) > 10  # errors were met, and kept
