"""Foxglove backend: the live node served over Foxglove's WebSocket protocol, no ROS needed.

A third :class:`~bubblerob_env.ros.live.backend.LiveBackend` beside ``rospy`` and ``rclpy``,
built on Foxglove's own SDK (``foxglove-sdk``, the ``foxglove`` extra). Every topic is a channel
of its ROS 2 type (``ros2msg`` schema, ``cdr`` encoding) carrying the CDR bytes the fan-out packs
for a ROS 2 bag, unchanged, so Foxglove decodes them as it decodes ``foxglove_bridge``'s.

What the protocol lacks is made up here, as ``foxglove_bridge`` users would expect:

- Latching: the server keeps nothing, so the latest message of a latched topic (``/tf_static``,
  ``/map``, ``simulationState``) is sent again whenever a client subscribes to it (it reaches
  every subscriber of that channel: harmless for latched data).
- Time: each message's stamp (its header's, else the latest one seen) is its log time, and the
  simulated time is broadcast (``time`` capability) as it advances, for Foxglove's playback bar.
- Client publishing: a client's channel (the Teleop panel's ``/cmd_vel``) reaches the
  subscribers of its topic as CDR; JSON messages (what the Teleop panel sends) are converted
  first (:mod:`~bubblerob_env.ros.live.foxglove_json`). A bad message is dropped and logged once
  per kind of fault and topic; it never reaches the simulation loop.
- Services: :meth:`FoxgloveBackend.add_trigger_service` (``std_srvs/srv/Trigger``, in CDR).
- Parameters: :meth:`FoxgloveBackend.set_parameters`, read-only (the node's settings).

Clients must offer the WebSocket subprotocol ``foxglove.sdk.v1``: the SDK answers HTTP 400 to
``foxglove.websocket.v1`` alone, the default of ``@foxglove/ws-protocol``'s examples.
"""

from __future__ import annotations

import logging
import struct
import threading
from collections.abc import Callable
from typing import Any, cast

from bubblerob_env.ros.live.backend import (
    BackendError,
    LiveBackend,
    Publish,
    RawCallback,
    RosUnavailableError,
)
from bubblerob_env.ros.live.foxglove_json import JsonMessageError, json_to_cdr
from bubblerob_env.ros.messages.distros import message_definition, typestore

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "SUBPROTOCOL",
    "FoxgloveBackend",
    "TriggerHandler",
    "stamp_offset",
]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
"""Foxglove's default port (``foxglove_bridge`` and the app's "Open connection" dialog)."""
SUBPROTOCOL = "foxglove.sdk.v1"
"""The WebSocket subprotocol a client must offer (``foxglove.websocket.v1`` gets HTTP 400)."""
TriggerHandler = Callable[[], tuple[bool, str]]
"""A ``std_srvs/srv/Trigger`` service: returns ``(success, message)``."""

_DISTRO = "jazzy"
_HEADER_TYPES = ("std_msgs/msg/Header", "builtin_interfaces/msg/Time")
_STAMP = struct.Struct("<iI")
_COUNT = struct.Struct("<I")
_TRIGGER_RESPONSE = "bool success # indicate successful run of triggered service\nstring message\n"


def stamp_offset(msgtype: str) -> tuple[int, bool] | None:
    """Where a CDR ``msgtype``'s stamp is: ``(byte offset, after a sequence count)`` or ``None``.

    A message that starts with a header (or is a ``Clock``) has it at byte 4, after CDR's
    encapsulation header; one that starts with a sequence of stamped messages (``TFMessage``,
    ``Detection2DArray``'s are headed) has its first item's at 8, when the sequence is not empty.
    """
    fields: list[tuple[str, Any]] = list(typestore(_DISTRO).fielddefs[msgtype][1])
    if not fields:
        return None
    node, detail = fields[0][1]
    if node == 2 and (detail in _HEADER_TYPES or stamp_offset(detail) == (4, False)):
        return 4, False
    if node == 4 and detail[0][0] == 2 and stamp_offset(detail[0][1]) == (4, False):
        return 8, True
    return None


class FoxgloveBackend(LiveBackend):
    """A Foxglove WebSocket server on ``host:port`` (0: a port the OS picks; see :attr:`port`)."""

    ros_version = 2
    distro = _DISTRO

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        name: str = "bubblerob",
        logger: Callable[[str, str], None] | None = None,
    ) -> None:
        """Start serving.

        Args:
            host: The address to listen on (``0.0.0.0``: every interface; loopback by default).
            port: The port; 0: a free one the OS picks.
            name: The server's name, which clients show.
            logger: ``logger(level, text)`` for :meth:`log`; default: Python's ``logging``
                (``bubblerob.foxglove``). Warnings also go to the clients as status messages.

        Raises:
            RosUnavailableError: ``foxglove-sdk`` is not installed (the ``foxglove`` extra).
            BackendError: The server cannot listen on ``host:port`` (in use, unknown host).
        """
        try:
            import foxglove
            from foxglove.websocket import Capability
        except ImportError as error:
            raise RosUnavailableError(
                f"foxglove-sdk is not importable ({error}): pip install 'bubblerob[foxglove]'"
            ) from None
        self._foxglove = foxglove
        self._logger = logger
        self._lock = threading.Lock()
        self._channels: dict[str, Any] = {}
        self._latched: dict[str, tuple[bytes, int]] = {}
        self._subscriptions: dict[str, list[tuple[str, RawCallback]]] = {}
        self._client_channels: dict[tuple[int, int], tuple[str, str, str]] = {}
        self._faults: set[tuple[str, str]] = set()
        self._subscribers: dict[str, int] = {}
        self._parameters: dict[str, bool | int | float | str] = {}
        self._now_ns = 0
        self._broadcast_ns = -1
        self._closed = False
        self._context = foxglove.Context()
        capabilities = [Capability.ClientPublish, Capability.Services, Capability.Time]
        capabilities.append(Capability.Parameters)
        try:
            self._server = foxglove.start_server(
                name=name,
                host=host,
                port=port,
                capabilities=capabilities,
                server_listener=cast(Any, _Listener(self)),
                supported_encodings=["json", "cdr"],
                context=self._context,
            )
        except RuntimeError as error:
            reason = str(error).removeprefix("FoxgloveError: ")
            hint = "pick another with --port (0: any free port)" if "in use" in reason else ""
            raise BackendError(
                f"Foxglove server cannot listen on {host}:{port}: {reason}"
                + (f"; {hint}" if hint else "")
            ) from None
        self.host = host

    @property
    def port(self) -> int:
        """The port the server listens on (the OS's choice when started with port 0)."""
        return int(self._server.port)

    @property
    def url(self) -> str:
        """``ws://host:port``, what Foxglove's "Open connection" dialog takes."""
        return f"ws://{self.host}:{self.port}"

    # -- LiveBackend ----------------------------------------------------------------------------

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        """See :meth:`LiveBackend.advertise`; advertising a topic twice shares its channel."""
        with self._lock:
            channel = self._channels.get(topic)
            if channel is None:
                text, _ = message_definition(_DISTRO, msgtype)
                schema = self._foxglove.Schema(name=msgtype, encoding="ros2msg", data=text.encode())
                channel = self._foxglove.Channel(
                    topic, schema=schema, message_encoding="cdr", context=self._context
                )
                self._channels[topic] = channel
        where = stamp_offset(msgtype)
        log = channel.log

        def publish(data: bytes) -> None:
            raw = data if type(data) is bytes else bytes(data)
            stamp = self._stamp(raw, where)
            if latched:
                self._latched[topic] = (raw, stamp)
            log(raw, log_time=stamp)

        return publish

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        """See :meth:`LiveBackend.subscribe`: messages that clients publish on ``topic``."""
        with self._lock:
            self._subscriptions.setdefault(topic, []).append((msgtype, callback))

    def ok(self) -> bool:
        """See :meth:`LiveBackend.ok`."""
        return not self._closed

    def shutdown(self, reason: str = "done") -> None:
        """See :meth:`LiveBackend.shutdown`: stops the server (clients see it close)."""
        if self._closed:
            return
        self._closed = True
        self._server.stop()

    def log(self, level: str, text: str) -> None:
        """See :meth:`LiveBackend.log`; a warning also shows in the clients' problems list."""
        if self._logger is not None:
            self._logger(level, text)
        else:
            logging.getLogger("bubblerob.foxglove").log(
                logging.WARNING if level == "warn" else logging.INFO, text
            )
        if level == "warn" and not self._closed:
            self._server.publish_status(text, self._foxglove.StatusLevel.Warning)

    # -- services -------------------------------------------------------------------------------

    def add_trigger_service(self, name: str, handler: TriggerHandler) -> None:
        """Serve ``name`` as a ``std_srvs/srv/Trigger``: a call runs ``handler``.

        Requests and responses are CDR (``ros2msg`` schemas), as ``foxglove_bridge`` serves a ROS 2
        service; Foxglove's Service Call panel encodes the (empty) request from the schema.
        """
        fox = self._foxglove

        def schema(kind: str, text: bytes) -> Any:
            data = fox.Schema(name=f"std_srvs/srv/Trigger_{kind}", encoding="ros2msg", data=text)
            return fox.MessageSchema(encoding="cdr", schema=data)

        def answer(request: Any) -> bytes:
            try:
                success, message = handler()
            except Exception as error:  # noqa: BLE001 - a failing call must not stop the server
                success, message = False, f"{type(error).__name__}: {error}"
            text = message.encode() + b"\0"
            return b"\0\1\0\0" + bytes([success, 0, 0, 0]) + _COUNT.pack(len(text)) + text

        service_schema = fox.ServiceSchema(
            "std_srvs/srv/Trigger",
            request=schema("Request", b""),
            response=schema("Response", _TRIGGER_RESPONSE.encode()),
        )
        self._server.add_services([fox.Service(name, schema=service_schema, handler=answer)])

    # -- internals ------------------------------------------------------------------------------

    def _stamp(self, raw: bytes, where: tuple[int, bool] | None) -> int:
        """The message's stamp in ns (else the latest seen); broadcasts time as it advances."""
        if where is not None:
            offset, counted = where
            if len(raw) >= offset + 8 and not (counted and _COUNT.unpack_from(raw, 4)[0] == 0):
                sec, nanosec = _STAMP.unpack_from(raw, offset)
                self._now_ns = max(self._now_ns, sec * 1_000_000_000 + nanosec)
        now = self._now_ns
        if now > self._broadcast_ns:
            self._broadcast_ns = now
            self._server.broadcast_time(now)
        return now

    def fault(self, kind: str, topic: str, detail: str) -> None:
        """Log a fault of a client's message once per kind and topic (later ones: silently)."""
        with self._lock:
            if (kind, topic) in self._faults:
                return
            self._faults.add((kind, topic))
        self.log("warn", f"ignoring {kind} on {topic}: {detail} (further ones are not logged)")

    def set_parameters(self, values: dict[str, bool | int | float | str]) -> None:
        """Read-only parameters that clients see (Foxglove's Parameters panel): the settings."""
        with self._lock:
            self._parameters.update(values)

    def parameters(self, names: list[str]) -> list[Any]:
        """The SDK's ``Parameter`` s of ``names`` (all of them where ``names`` is empty)."""
        with self._lock:
            chosen = {n: v for n, v in self._parameters.items() if not names or n in names}
        fox = self._foxglove
        # A whole float (1.0) would go out as an integer without its type.
        return [
            fox.Parameter(name, value=v, type=fox.ParameterType.Float64)
            if isinstance(v, float)
            else fox.Parameter(name, value=v)
            for name, v in chosen.items()
        ]

    def subscribers(self, topic: str) -> int:
        """How many client subscriptions ``topic`` has now."""
        return self._subscribers.get(topic, 0)

    def watched(self) -> bool:
        """Whether any client subscribes to any topic now."""
        with self._lock:
            return any(count > 0 for count in self._subscribers.values())

    def count_subscriber(self, topic: str, change: int) -> None:
        """A client subscribed to ``topic`` (+1) or left it (-1)."""
        with self._lock:
            self._subscribers[topic] = self._subscribers.get(topic, 0) + change

    def resend_latched(self, topic: str) -> None:
        """Send ``topic``'s latest message again if it is latched (a client just subscribed)."""
        latest = self._latched.get(topic)
        channel = self._channels.get(topic)
        if latest is not None and channel is not None and not self._closed:
            channel.log(latest[0], log_time=latest[1])

    def client_advertised(
        self, client: int, channel: int, topic: str, encoding: str, schema: str
    ) -> None:
        """Remember a client's channel (its topic, encoding, and the type it claims)."""
        with self._lock:
            self._client_channels[(client, channel)] = (topic, encoding, schema)

    def client_unadvertised(self, client: int, channel: int) -> None:
        """Forget a client's channel."""
        with self._lock:
            self._client_channels.pop((client, channel), None)

    def client_message(self, client: int, channel: int, data: bytes) -> None:
        """Hand a client's message to the subscribers of its topic, as CDR."""
        with self._lock:
            known = self._client_channels.get((client, channel))
            subscribers = list(self._subscriptions.get(known[0], ())) if known else []
        if known is None:
            self.fault("a message", f"client channel {channel}", "the client never advertised it")
            return
        topic, encoding, claimed = known
        if not subscribers:
            self.fault("messages", topic, "nothing here subscribes to that topic")
            return
        sender = f"Foxglove client {client}"
        # The node checks the claimed type, ROS 1 style (pkg/Type): a mismatch goes through as is.
        msgtype = "/".join(claimed.split("/")[::2]) if claimed.count("/") == 2 else claimed
        for wanted, callback in subscribers:
            raw = data
            if encoding == "json" and msgtype in ("", wanted.replace("/msg/", "/")):
                try:
                    raw = json_to_cdr(_DISTRO, wanted, data)
                except JsonMessageError as error:
                    self.fault("malformed JSON", topic, f"{error} (from {sender})")
                    return
            elif encoding not in ("json", "cdr"):
                self.fault(f"{encoding!r} messages", topic, "send json or cdr")
                return
            try:
                callback(raw, msgtype or None, sender)
            except Exception as error:  # noqa: BLE001 - no message may stop the server
                self.fault("an unusable message", topic, f"{error!r} (from {sender})")


class _Listener:
    """The SDK's ``ServerListener``, forwarding to the backend (on the server's threads)."""

    def __init__(self, backend: FoxgloveBackend) -> None:
        self.backend = backend

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.backend.count_subscriber(channel.topic, 1)
        self.backend.resend_latched(channel.topic)

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        self.backend.count_subscriber(channel.topic, -1)

    def on_client_advertise(self, client: Any, channel: Any) -> None:
        self.backend.client_advertised(
            client.id, channel.id, channel.topic, channel.encoding, channel.schema_name or ""
        )

    def on_client_unadvertise(self, client: Any, client_channel_id: int) -> None:
        self.backend.client_unadvertised(client.id, client_channel_id)

    def on_message_data(self, client: Any, client_channel_id: int, data: bytes) -> None:
        self.backend.client_message(client.id, client_channel_id, bytes(data))

    def on_get_parameters(
        self, client: Any, param_names: list[str], request_id: str | None = None
    ) -> list[Any]:
        return self.backend.parameters(param_names)

    def on_set_parameters(
        self, client: Any, parameters: list[Any], request_id: str | None = None
    ) -> list[Any]:
        names = [p.name for p in parameters]
        self.backend.fault("a parameter change", ", ".join(names), "the parameters are read-only")
        return self.backend.parameters(names)

    def on_parameters_subscribe(self, param_names: list[str]) -> None:
        return None

    def on_parameters_unsubscribe(self, param_names: list[str]) -> None:
        return None
