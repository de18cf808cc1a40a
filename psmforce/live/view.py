"""Looking at the estimate: a Foxglove layout, a ROS 2 MCAP writer, and a live Foxglove
WebSocket server (``foxglove-sdk``, the optional extra ``psmforce[ros]``).

Every channel carries CDR bytes under its ROS 2 type with the ``ros2msg`` schema from
:data:`psmforce.io.bags.messages.ROS2_TYPESTORE`: the MCAP profile ``ros2`` that Foxglove and
PlotJuggler open, and what the WebSocket server advertises. :func:`layout` is a Foxglove layout
(import it with "Import layout from file"): one plot per axis, the estimate in the HEX10 frame
against the HEX10's raw reading and, where recorded, the ATI's raw reading (in the ATI's own
frame: compare shapes, not signs, unless the frames are aligned).
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

from psmforce.core.files import write_text_atomic
from psmforce.io.bags.messages import ROS2_TYPESTORE


def schema_text(msgtype: str) -> str:
    """The ``ros2msg`` schema of a ROS 2 message type, dependencies included."""
    return ROS2_TYPESTORE.generate_msgdef(msgtype, ros_version=2)[0]


def layout(estimate_topic: str, hex10_topic: str, ati_topic: str | None) -> dict:
    """A Foxglove layout: force x, y, z of the estimate, the HEX10 and the ATI (module
    docstring)."""
    panels = {}
    for axis in "xyz":
        paths = [{"value": f"{estimate_topic}.wrench.force.{axis}", "enabled": True,
                  "label": f"estimate f{axis} (HEX10 frame)"},
                 {"value": f"{hex10_topic}.wrench.force.{axis}", "enabled": True,
                  "label": f"HEX10 raw f{axis}"}]
        if ati_topic:
            paths.append({"value": f"{ati_topic}.wrench.force.{axis}", "enabled": True,
                          "label": f"ATI raw f{axis} (ATI frame)"})
        panels[f"Plot!force_{axis}"] = {"paths": paths, "showLegend": True,
                                        "xAxisVal": "timestamp", "title": f"force {axis} (N)"}
    return {"configById": panels, "globalVariables": {}, "userNodes": {},
            "playbackConfig": {"speed": 1},
            "layout": {"direction": "column", "first": "Plot!force_x",
                       "second": {"direction": "column", "first": "Plot!force_y",
                                  "second": "Plot!force_z", "splitPercentage": 50},
                       "splitPercentage": 33}}


def write_layout(path: str | Path, *args) -> Path:
    """Write :func:`layout` (``args``: its arguments) as JSON to ``path``."""
    path = Path(path)
    write_text_atomic(path, json.dumps(layout(*args), indent=2) + "\n")
    return path


class McapOut:
    """A ROS 2 MCAP file of CDR messages (module docstring); topics registered on first use."""

    def __init__(self, path: str | Path):
        from mcap.writer import Writer
        self._file = open(path, "wb")
        self._writer = Writer(self._file)
        self._writer.start(profile="ros2", library="psmforce")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self.counts: dict[str, int] = {}

    def write(self, topic: str, msgtype: str, data: bytes, log_ns: int) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            schema = self._schemas.get(msgtype)
            if schema is None:
                schema = self._schemas[msgtype] = self._writer.register_schema(
                    msgtype, "ros2msg", schema_text(msgtype).encode())
            channel = self._channels[topic] = self._writer.register_channel(topic, "cdr", schema)
        self._writer.add_message(channel, log_time=log_ns, data=data, publish_time=log_ns)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def close(self) -> None:
        """Finish the file (once; a second call does nothing)."""
        if not self._file.closed:
            self._writer.finish()
            self._file.close()


class LiveView:
    """A Foxglove WebSocket server on ``host:port`` (0: a free port, :attr:`port` tells which)
    with a context of its own. ``channels`` (topic -> ROS 2 type) are advertised before the
    server starts, so a client sees every one of them from its first message, whenever it
    connects; a topic first logged later is advertised then. :meth:`wait_for_subscriber` lets a
    player wait for a viewer before it starts."""

    def __init__(self, port: int = 8765, host: str = "127.0.0.1",
                 channels: dict[str, str] | None = None):
        import foxglove
        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._channels: dict[str, object] = {}
        for topic, msgtype in (channels or {}).items():
            self._channel(topic, msgtype)
        self._subscribed: set[str] = set()
        self._changed = threading.Condition()
        self.server = foxglove.start_server(name="psmforce", host=host, port=port,
                                            context=self._context,
                                            server_listener=_Subscriptions(self))
        self.port = self.server.port

    def _channel(self, topic: str, msgtype: str):
        channel = self._channels.get(topic)
        if channel is None:
            fox = self._foxglove
            schema = fox.Schema(name=msgtype, encoding="ros2msg",
                                data=schema_text(msgtype).encode())
            channel = self._channels[topic] = fox.Channel(topic, schema=schema,
                                                          message_encoding="cdr",
                                                          context=self._context)
        return channel

    def _on_subscribe(self, topic: str) -> None:
        with self._changed:
            self._subscribed.add(topic)
            self._changed.notify_all()

    def wait_for_subscriber(self, topic: str, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for a client to subscribe to ``topic``; True once one has
        (at any time since the server started)."""
        with self._changed:
            return self._changed.wait_for(lambda: topic in self._subscribed, timeout_s)

    def write(self, topic: str, msgtype: str, data: bytes, log_ns: int) -> None:
        self._channel(topic, msgtype).log(data, log_time=log_ns)

    def hold(self, seconds: float | None) -> None:
        """Keep serving for ``seconds`` (None: until interrupted)."""
        end = None if seconds is None else time.monotonic() + seconds
        while end is None or time.monotonic() < end:
            time.sleep(0.05)

    def close(self) -> None:
        self.server.stop()


class _Subscriptions:
    """The server's listener (``foxglove.ServerListener``): tells the view which topics a
    client subscribed to. The SDK calls every callback a client's actions imply (a viewer
    that disconnects unsubscribes from each channel); one it cannot find is printed as a
    callback error, so each is answered here, the ones the view has no use for by nothing."""

    def __init__(self, view: LiveView):
        self._view = view

    def on_subscribe(self, client, channel) -> None:
        self._view._on_subscribe(channel.topic)

    def on_unsubscribe(self, client, channel) -> None:
        """Nothing to do: :meth:`LiveView.wait_for_subscriber` asks whether a client has
        ever subscribed."""

    def on_client_advertise(self, client, channel) -> None:
        """Nothing to do: the view publishes, it does not take a client's messages."""

    def on_client_unadvertise(self, client, client_channel_id) -> None:
        """Nothing to do (as :meth:`on_client_advertise`)."""

    def on_message_data(self, client, client_channel_id, data) -> None:
        """Nothing to do (as :meth:`on_client_advertise`)."""
