"""psmforce/live/discovery.py: the domain and the discovery range read as ROS 2 Jazzy reads
them, and refused in one line outside what it allows (over DDS between processes:
``tests/live/test_live_dds.py``)."""

import pytest

from psmforce.live.discovery import _discovery_config, discovery, domain


def test_the_discovery_range_is_read_as_ros_2_jazzy_reads_it(monkeypatch):
    """Issue 47, item 7: ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS and ROS_LOCALHOST_ONLY
    were ignored; a domain outside [0, 232] was an internal error."""
    for name in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY"):
        monkeypatch.delenv(name, raising=False)
    assert discovery() == ("SUBNET", []) and _discovery_config("SUBNET", []) is None
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "localhost")
    monkeypatch.setenv("ROS_STATIC_PEERS", "10.0.0.7; robot.lab")
    assert discovery() == ("LOCALHOST", ["10.0.0.7", "robot.lab"])
    config = _discovery_config(*discovery())
    assert '127.0.0.1' in config and '<Peer address="localhost"/>' in config \
        and '<Peer address="robot.lab"/>' in config
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    monkeypatch.setenv("ROS_LOCALHOST_ONLY", "1")  # deprecated in Jazzy, and it wins
    assert discovery()[0] == "LOCALHOST"
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "lan")
    with pytest.raises(ValueError, match="ROS_AUTOMATIC_DISCOVERY_RANGE must be one of"):
        discovery()
    for bad in (300, -5, True):
        with pytest.raises(ValueError, match=r"domain must be an integer in \[0, 232\]"):
            domain(bad)
