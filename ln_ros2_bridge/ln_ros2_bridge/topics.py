"""Topic bridges. Data path: packet bytes -> codec -> CDR bytes -> raw publish,
and the reverse; no message objects and no per-field Python in between."""

import logging
import threading
import time

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .ros_senders import SenderFilter, endpoint_gid, publisher_gid, want_sender

log = logging.getLogger("ln_ros2_bridge.topics")

_RELIABILITY = {"reliable": ReliabilityPolicy.RELIABLE, "best_effort": ReliabilityPolicy.BEST_EFFORT,
                "best_available": ReliabilityPolicy.BEST_AVAILABLE}
_DURABILITY = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL,
               "best_available": DurabilityPolicy.BEST_AVAILABLE}
_HISTORY = {"keep_last": HistoryPolicy.KEEP_LAST, "keep_all": HistoryPolicy.KEEP_ALL}


def qos_profile(qos, for_publisher):
    """rclpy QoS from the configuration's Qos. A publisher cannot be
    "best available": it offers reliable / volatile then, which every reader accepts
    except transient-local ones (configure those explicitly)."""
    reliability, durability = qos.reliability, qos.durability
    if for_publisher:
        reliability = "reliable" if reliability == "best_available" else reliability
        durability = "volatile" if durability == "best_available" else durability
    return QoSProfile(reliability=_RELIABILITY[reliability], durability=_DURABILITY[durability],
                      history=_HISTORY[qos.history], depth=qos.depth)


class _RateLimitedLog:
    """Logs a recurring problem at most every `period` seconds, with a count."""

    def __init__(self, logger, period=5.0):
        self._logger = logger
        self._period = period
        self._last = 0.0
        self._suppressed = 0

    def __call__(self, message, *args):
        now = time.monotonic()
        if now - self._last >= self._period:
            if self._suppressed:
                message += " (%d more since the last report)" % self._suppressed
            self._logger.warning(message, *args)
            self._last, self._suppressed = now, 0
        else:
            self._suppressed += 1


class LnToRosTopic:
    """An LN subscription republished on a ROS topic by a reader thread of its own
    (LN's blocking read releases the GIL; the ROS executor is not involved)."""

    direction = "ln_to_ros"

    def __init__(self, node, ln, entry, topic_type, on_broken=None):
        self.entry = entry
        self.topic_type = topic_type
        self.count = 0
        self.errors = 0
        self._node = node
        self._ln = ln
        self._on_broken = on_broken
        self._stop = threading.Event()
        self._warn = _RateLimitedLog(log)
        settings = entry.ln_port
        self.port = ln.subscribe(entry.ln, topic_type.ln_name, rate=settings.rate, buffers=settings.buffers,
                                 reliable=settings.reliable_transport)
        if self.port.size != topic_type.ln_size:
            ln.unsubscribe(self.port)
            raise ValueError("LN topic %s carries %d-byte packets but %s is %d bytes: the definitions differ"
                             % (entry.ln, self.port.size, topic_type.ln_name, topic_type.ln_size))
        self.publisher = node.create_publisher(topic_type.msg_class, entry.ros, qos_profile(entry.qos, True))
        self._thread = threading.Thread(target=self._run, name="ln->ros " + entry.ln, daemon=True)
        self._thread.start()

    def _run(self):
        read, to_cdr, publish = self.port.read, self.topic_type.codec.ln_to_cdr, self.publisher.publish
        while not self._stop.is_set():
            try:
                data = read(0.25)   # bounded, so that close() is noticed
            except Exception as error:
                if self._stop.is_set():
                    break
                log.warning("LN topic %s: read failed (%s); the bridge will reconnect", self.entry.ln, error)
                if self._on_broken:
                    self._on_broken(error)
                break
            if data is None:
                continue
            try:
                publish(to_cdr(data))
                self.count += 1
            except Exception as error:   # a packet the codec rejects must not stop the topic
                self.errors += 1
                self._warn("LN topic %s -> %s: dropped a packet: %s", self.entry.ln, self.entry.ros, error)

    def close(self):
        self._stop.set()
        try:
            self.port.unblock()
        except Exception:
            pass
        self._thread.join(timeout=2.0)
        try:
            self._node.destroy_publisher(self.publisher)
        except Exception:
            pass
        try:
            self._ln.unsubscribe(self.port)
        except Exception:
            pass


class RosToLnTopic:
    """A raw ROS subscription written into an LN topic this bridge publishes.

    Loop prevention: messages from bridge publishers (this bridge's and other
    bridges', is_bridge_node on the publisher's node) came from LN and must not go
    back. Per publisher where the message says who sent it (SenderAwareExecutor,
    see ros_senders): a bridge's messages are dropped, everybody else's forwarded,
    on the same topic.

    Without the sender (rclpy's plain take) the decision is per topic, from the
    ROS graph: while every publisher on the topic is a bridge, messages are
    dropped; a publisher whose node is not known yet counts as a bridge for up to
    PENDING seconds; the graph is looked at again whenever the subscription's
    publisher count changes, so a bridge publisher that appears is caught before
    its first message is forwarded. If bridges and others share the topic, all of
    it goes to LN, and a warning says so."""

    direction = "ros_to_ln"
    PENDING = SenderFilter.PENDING
    UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"

    def __init__(self, node, ln, entry, topic_type, is_bridge_node):
        self.entry = entry
        self.topic_type = topic_type
        self.count = 0
        self.errors = 0
        self._ignored = 0   # messages dropped by the per-topic decision
        self._node = node
        self._ln = ln
        self._is_bridge_node = is_bridge_node
        self._warn = _RateLimitedLog(log)
        self._write_lock = threading.Lock()   # the packet buffer: executor thread and reconciler
        self._senders = SenderFilter(entry.ros, self._publisher_nodes, is_bridge_node, hold=entry.qos.depth)
        self._per_publisher = False
        self._publisher_count = -1
        self._forward = False
        self._pending_since = None
        self._mixed = None   # (bridges, others) publishing the topic, when both do
        self._mixed_reported = False
        self.port = ln.publish(entry.ln, topic_type.ln_name, entry.ln_port.buffers)
        if len(self.port.buffer) != topic_type.ln_size:
            ln.unpublish(self.port)
            raise ValueError("LN topic %s carries %d-byte packets but %s is %d bytes: the definitions differ"
                             % (entry.ln, len(self.port.buffer), topic_type.ln_name, topic_type.ln_size))
        # One callback at a time per topic (the packet buffer is shared), topics in parallel.
        self.subscription = want_sender(node.create_subscription(
            topic_type.msg_class, entry.ros, self._on_message, qos_profile(entry.qos, False),
            callback_group=MutuallyExclusiveCallbackGroup(), raw=True))

    @property
    def ignored(self):
        """Messages not forwarded because a bridge sent them."""
        return self._senders.dropped + self._ignored

    def _publisher_nodes(self):
        """{gid: fully qualified node name, "" when not known yet} of the topic's publishers."""
        nodes = {}
        for i in self._node.get_publishers_info_by_topic(self.entry.ros):
            known = i.node_name and i.node_name != self.UNKNOWN_NODE
            nodes[endpoint_gid(i)] = ((i.node_namespace.rstrip("/") + "/" + i.node_name) if known else "")
        return nodes

    def refresh_sources(self):
        """Re-reads who publishes the topic (called by the bridge every pass): held
        messages whose publisher is known now are forwarded or dropped."""
        with self._write_lock:
            for cdr, stamp in self._senders.resolve():
                self._write(cdr, stamp)
        if not self._per_publisher:
            self._refresh_topic_sources()

    def _refresh_topic_sources(self):
        self._publisher_count = self.subscription.get_publisher_count()
        nodes = [i.node_name for i in self._node.get_publishers_info_by_topic(self.entry.ros)]
        bridges = [n for n in nodes if self._is_bridge_node(n)]
        unknown = [n for n in nodes if n == self.UNKNOWN_NODE]
        others = [n for n in nodes if n not in bridges and n not in unknown]
        self._mixed = (bridges, others) if bridges and others else None
        if others:
            self._forward, self._pending_since = True, None
        elif unknown:
            now = time.monotonic()
            self._pending_since = self._pending_since or now
            self._forward = now - self._pending_since >= self.PENDING
        else:
            self._forward, self._pending_since = False, None

    def _on_message(self, cdr, info):
        stamp = info.get("source_timestamp")
        gid = publisher_gid(info)
        with self._write_lock:
            if gid is not None:
                self._per_publisher = True
                for held_cdr, held_stamp in self._senders.admit(gid, (cdr, stamp)):
                    self._write(held_cdr, held_stamp)
                return
            if self._pending_since is not None or self.subscription.get_publisher_count() != self._publisher_count:
                self._refresh_topic_sources()
            if not self._forward:
                self._ignored += 1
                return
            if self._mixed and not self._mixed_reported:
                self._mixed_reported = True
                log.warning("ROS topic %s has publishers from bridges (%s) and from others (%s): without the "
                            "sender of each message, the bridges' messages go to LN %s too",
                            self.entry.ros, ", ".join(self._mixed[0]), ", ".join(self._mixed[1]), self.entry.ln)
            self._write(cdr, stamp)

    def _write(self, cdr, stamp):
        try:
            self.topic_type.cdr_to_ln_into(cdr, self.port.buffer)
            self.port.write(stamp / 1e9 if stamp else None)
            self.count += 1
        except Exception as error:   # e.g. a string longer than the LN field: drop this one
            self.errors += 1
            self._warn("ROS topic %s -> LN %s: dropped a message: %s", self.entry.ros, self.entry.ln, error)

    def close(self):
        try:
            self._node.destroy_subscription(self.subscription)
        except Exception:
            pass
        try:
            self._ln.unpublish(self.port)
        except Exception:
            pass
