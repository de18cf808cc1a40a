"""Issue 47, item 7: the RIHS01 type hash of every message type the node uses, computed from
its definition here, equals the one ``rosbags`` computes independently from its own type store."""

from __future__ import annotations

import pytest

from psmforce.io.bags import ROS2_TYPESTORE
from psmforce.live.node import OUTPUT_TYPES, TARE_TYPE
from psmforce.live.type_hash import DEFINITIONS, rihs01, user_data


@pytest.mark.parametrize("type_name", sorted(DEFINITIONS))
def test_each_hash_equals_the_independent_computation(type_name):
    assert rihs01(type_name) == ROS2_TYPESTORE.hash_rihs01(type_name)


def test_every_type_the_node_reads_or_writes_has_a_definition():
    used = {*OUTPUT_TYPES.values(), TARE_TYPE, "sensor_msgs/msg/JointState",
            "geometry_msgs/msg/WrenchStamped"}
    assert used <= set(DEFINITIONS)
    assert user_data("std_msgs/msg/UInt32") == (
        b"typehash=" + ROS2_TYPESTORE.hash_rihs01("std_msgs/msg/UInt32").encode() + b";")


def test_a_changed_definition_changes_the_hash(monkeypatch):
    """The check can fail: one field's type changed is another type."""
    before = rihs01("std_msgs/msg/Header")
    monkeypatch.setitem(DEFINITIONS, "builtin_interfaces/msg/Time",
                        (("sec", "int64"), ("nanosec", "uint32")))
    assert rihs01("std_msgs/msg/Header") != before
    with pytest.raises(KeyError, match="no definition"):
        rihs01("std_msgs/msg/String")
