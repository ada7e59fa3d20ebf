"""ROS 1 backend: ``rospy`` publishing pre-serialised bytes, control messages received raw.

``rospy`` comes from a ROS install or Debian (``python3-rospy``). From a virtualenv it is found by
*appending* Debian's ``dist-packages`` to ``sys.path`` (never prepending: Debian's NumPy must not
shadow the venv's). Every topic is published with a message class whose ``serialize`` writes
bytes made by :mod:`~bubblerob_env.ros.fastpath`, declaring the genuine type, md5sum and full
definition, so that ``rostopic echo``, ``rosbag record`` and typed subscribers accept it. Control
topics are subscribed with their type (the master and ``rostopic type`` know it) but md5sum
``*``, as ``rospy.AnyMsg`` is: every sender connects, its declared type is checked here and wrongly
typed messages are reported instead of being silently refused by the middleware.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
import warnings
import xmlrpc.client
from types import ModuleType
from typing import Any
from urllib.parse import urlparse

from bubblerob_env.ros.live.backend import (
    LiveBackend,
    MasterUnreachableError,
    Publish,
    RawCallback,
    RosUnavailableError,
)
from bubblerob_env.ros.messages.distros import message_definition
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = ["DEBIAN_DIST_PACKAGES", "Ros1Backend", "check_master", "import_rospy", "ros1_msgdef"]

DEBIAN_DIST_PACKAGES = "/usr/lib/python3/dist-packages"
DEFAULT_MASTER_URI = "http://localhost:11311/"
INSTALL_HINT = (
    "install Debian's ROS 1 client library (apt-get install python3-rospy) or source a ROS 1 "
    "install (source /opt/ros/noetic/setup.bash)"
)
QUEUE_SIZE: int | None = None
"""Default publisher queue: ``None`` writes to each subscriber's socket in the publishing thread
(about 3x the steps/s of rospy's queued publishing, see ``bench/live_speed.py``); a number gives
each subscriber a queue and a writer thread, so that a stalled subscriber cannot block the node."""


def import_rospy() -> ModuleType:
    """Import ``rospy``, appending Debian's ``dist-packages`` to ``sys.path`` if needed."""
    try:
        import rospy  # type: ignore[import-not-found,import-untyped,unused-ignore]
    except ImportError:
        if not os.path.isdir(DEBIAN_DIST_PACKAGES) or DEBIAN_DIST_PACKAGES in sys.path:
            raise RosUnavailableError(f"rospy is not importable: {INSTALL_HINT}") from None
        sys.path.append(DEBIAN_DIST_PACKAGES)  # appended: the venv's packages keep precedence
        try:
            import rospy  # type: ignore[import-not-found,import-untyped,unused-ignore]
        except ImportError as error:
            raise RosUnavailableError(
                f"rospy is not importable ({error}): {INSTALL_HINT}"
            ) from None
    return rospy  # type: ignore[no-any-return]


def check_master(uri: str | None = None, timeout: float = 3.0) -> str:
    """Wait up to ``timeout`` s for the master to answer; return its URI or raise.

    Raises :class:`MasterUnreachableError` naming ``ROS_MASTER_URI`` when none answers. ``uri``
    defaults to ``ROS_MASTER_URI`` (and, like ROS, ``http://localhost:11311/`` if unset).
    """
    source = "ROS_MASTER_URI"
    if uri is None:
        uri = os.environ.get("ROS_MASTER_URI")
        if not uri:
            uri, source = DEFAULT_MASTER_URI, "ROS_MASTER_URI (unset, so the default)"
    parsed = urlparse(uri)
    if parsed.scheme != "http" or not parsed.hostname:
        raise MasterUnreachableError(
            f"{source}={uri!r} is not a master URI; it should look like http://localhost:11311"
        )
    deadline = time.monotonic() + timeout
    last = ""
    while True:
        left = max(0.05, deadline - time.monotonic())
        try:
            proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(min(left, 1.0)))
            answer: Any = proxy.getPid("/bubblerob_probe")
            code = answer[0]
            if code == 1:
                return uri
            last = f"it answered with code {code}"
        except (OSError, xmlrpc.client.Error) as error:
            last = str(error) or type(error).__name__
        if time.monotonic() >= deadline:
            break
        time.sleep(0.2)
    raise MasterUnreachableError(
        f"no ROS master reachable at {source}={uri} within {timeout:g} s ({last}); start one "
        "with `roscore` (or `rosmaster --core`), or set ROS_MASTER_URI to where it runs"
    )


class _TimeoutTransport(xmlrpc.client.Transport):
    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host: Any) -> Any:
        connection = super().make_connection(host)
        connection.timeout = self._timeout
        return connection


def ros1_msgdef(msgtype: str) -> tuple[str, str, str]:
    """``(ROS 1 type name, md5sum, full definition)`` of ``msgtype`` (``pkg/msg/Type``)."""
    text, md5sum = message_definition("noetic", msgtype)
    return msgtype.replace("/msg/", "/"), md5sum, text


class Ros1Backend(LiveBackend):
    """A ``rospy`` node (see the module docstring)."""

    ros_version = 1
    distro = "noetic"

    def __init__(
        self,
        node_name: str = "bubblerob",
        namespace: str = "",
        anonymous: bool = False,
        master_timeout: float = 3.0,
        queue_size: int | None = QUEUE_SIZE,
    ) -> None:
        """Check the master, then start the node ``/<namespace>/<node_name>``.

        ``queue_size``: see :data:`QUEUE_SIZE`.

        Raises:
            RosUnavailableError: ``rospy`` is not importable.
            MasterUnreachableError: No master answered within ``master_timeout`` seconds.
        """
        ns = namespace_prefix(namespace) + "/" if namespace_prefix(namespace) else ""
        if ns:  # rospy reads the node's namespace from ROS_NAMESPACE when first imported
            os.environ["ROS_NAMESPACE"] = ns
        self._rospy = rospy = import_rospy()
        if ns and hasattr(rospy.names, "_caller_namespace"):
            rospy.names._caller_namespace = ns  # imported before: no public way to change it
        check_master(timeout=master_timeout)
        rospy.init_node(node_name, argv=[], anonymous=anonymous, disable_signals=True)
        self._queue_size = queue_size
        self._publishers: list[Any] = []
        self._subscribers: list[Any] = []
        self._classes: dict[str, type] = {}
        self.lost_master: str | None = None
        """Why the node stopped itself: its master went away or restarted (``None``: it did not)."""
        uri = os.environ.get("ROS_MASTER_URI") or DEFAULT_MASTER_URI
        threading.Thread(target=self._watch_master, args=(uri,), daemon=True).start()

    def _watch_master(self, uri: str, interval: float = 1.0, patience: float = 3.0) -> None:
        """Stop the node when its master is gone for ``patience`` s, or forgot it (restarted).

        rospy never registers again with a new master, so a node that went on would publish to
        nobody, silently; it stops instead, with :attr:`lost_master` saying why, so that
        ``bubblerob node`` exits non-zero and a supervisor (``roslaunch respawn``, systemd) can
        start it again.
        """
        rospy = self._rospy
        name = rospy.get_name()
        failing_since: float | None = None
        while not rospy.is_shutdown():
            time.sleep(interval)
            try:
                proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(interval))
                answer: Any = proxy.lookupNode("/bubblerob_watch", name)
                code = answer[0]
            except (OSError, xmlrpc.client.Error) as error:
                failing_since = failing_since or time.monotonic()
                if time.monotonic() - failing_since < patience:
                    continue
                reason = f"the ROS master at {uri} is gone ({error or type(error).__name__})"
            else:
                failing_since = None
                if code == 1 or rospy.is_shutdown():
                    continue
                reason = f"the ROS master at {uri} restarted and no longer knows {name}"
            self.lost_master = reason
            rospy.logerr(f"{reason}: stopping")
            rospy.signal_shutdown(reason)
            return

    def _raw_class(self, msgtype: str) -> type:
        if msgtype not in self._classes:
            name, md5sum, text = ros1_msgdef(msgtype)
            self._classes[msgtype] = type(
                "Raw_" + name.replace("/", "_"),
                (self._rospy.AnyMsg,),
                {"_type": name, "_md5sum": md5sum, "_full_text": text, "__slots__": ()},
            )
        return self._classes[msgtype]

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        """See :meth:`LiveBackend.advertise`."""
        cls = self._raw_class(msgtype)
        with warnings.catch_warnings():  # rospy warns about queue_size=None: it is meant here
            warnings.simplefilter("ignore")
            publisher = self._rospy.Publisher(
                topic, cls, queue_size=self._queue_size, latch=latched
            )
        self._publishers.append(publisher)
        message = cls()

        def publish(data: bytes) -> None:
            message._buff = data
            publisher.publish(message)

        return publish

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        """See :meth:`LiveBackend.subscribe`; ``msgtype`` is what the sender declared."""

        def receive(message: Any) -> None:
            header = getattr(message, "_connection_header", None) or {}
            callback(message._buff or b"", header.get("type"), header.get("callerid", "?"))

        name, _, text = ros1_msgdef(msgtype)
        typed_any = type(  # AnyMsg that names its type: registered as such, accepts any sender
            "Any_" + name.replace("/", "_"),
            (self._rospy.AnyMsg,),
            {"_type": name, "_md5sum": "*", "_full_text": text, "__slots__": ()},
        )
        self._subscribers.append(
            self._rospy.Subscriber(topic, typed_any, receive, tcp_nodelay=True)
        )

    def ok(self) -> bool:
        """See :meth:`LiveBackend.ok`."""
        return not self._rospy.is_shutdown()

    def shutdown(self, reason: str = "done") -> None:
        """See :meth:`LiveBackend.shutdown`."""
        for handle in (*self._subscribers, *self._publishers):
            with contextlib.suppress(Exception):  # best effort while shutting down
                handle.unregister()
        self._subscribers.clear()
        self._publishers.clear()
        if not self._rospy.is_shutdown():
            self._rospy.signal_shutdown(reason)

    def log(self, level: str, text: str) -> None:
        """See :meth:`LiveBackend.log`."""
        (self._rospy.logwarn if level == "warn" else self._rospy.loginfo)(text)
