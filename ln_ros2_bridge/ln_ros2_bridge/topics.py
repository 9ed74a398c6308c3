"""Topic bridges. Their messages never pass through Python: each direction is a
compiled path of msg_mapping (msg_mapping._native.bridge) with a thread of its
own --

* LN -> ROS: LN read (in place on ln_core) -> codec -> rcl_publish_serialized_message
  on a publisher made by rclpy;
* ROS -> LN: rcl_take_serialized_message with the sending publisher's gid ->
  loop prevention -> codec -> LN write, on an rcl subscription the path makes
  itself (so that no rclpy executor takes from it).

The classes here make and close the paths and turn their reports into log
lines and the numbers the diagnostics show."""

import logging
import time

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

log = logging.getLogger("ln_ros2_bridge.topics")

_RELIABILITY = {
    "reliable": ReliabilityPolicy.RELIABLE,
    "best_effort": ReliabilityPolicy.BEST_EFFORT,
    "best_available": ReliabilityPolicy.BEST_AVAILABLE,
}
_DURABILITY = {
    "volatile": DurabilityPolicy.VOLATILE,
    "transient_local": DurabilityPolicy.TRANSIENT_LOCAL,
    "best_available": DurabilityPolicy.BEST_AVAILABLE,
}
_HISTORY = {"keep_last": HistoryPolicy.KEEP_LAST, "keep_all": HistoryPolicy.KEEP_ALL}


def qos_profile(qos, for_publisher):
    """rclpy QoS from the configuration's Qos. A publisher cannot be
    "best available": it offers reliable / volatile then, which every reader accepts
    except transient-local ones (configure those explicitly)."""
    reliability, durability = qos.reliability, qos.durability
    if for_publisher:
        reliability = "reliable" if reliability == "best_available" else reliability
        durability = "volatile" if durability == "best_available" else durability
    return QoSProfile(
        reliability=_RELIABILITY[reliability],
        durability=_DURABILITY[durability],
        history=_HISTORY[qos.history],
        depth=qos.depth,
    )


class _TopicBridge:
    """What both directions share: the compiled path's report, made readable."""

    REPORT_PERIOD = 5.0  # seconds between log lines about dropped messages of one topic

    def __init__(self, entry, topic_type):
        self.entry = entry
        self.topic_type = topic_type
        self.path = None
        self.last = {"received": 0, "forwarded": 0, "errors": 0, "lost": 0, "ignored": 0, "held": 0}
        self._unreported = 0
        self._last_text = ""
        self._reported_at = 0.0

    @property
    def count(self):
        return self.last["forwarded"]

    @property
    def errors(self):
        return self.last["errors"]

    def poll(self):
        """Reads the path's report: logs dropped messages (at most every REPORT_PERIOD
        per topic) and publishers without a node; returns the report. A report with
        "failed" means the path stopped (its LN connection is gone)."""
        report = self.path.report()
        self.last = report
        if report["new_errors"]:
            self._unreported += report["new_errors"]
            self._last_text = report["error_text"]
        now = time.monotonic()
        if self._unreported and now - self._reported_at >= self.REPORT_PERIOD:
            log.warning(
                "%s: dropped %d message%s: %s%s",
                self.describe(),
                self._unreported,
                "s" * (self._unreported != 1),
                self._last_text,
                _hint(self._last_text),
            )
            self._unreported, self._reported_at = 0, now
        for gid in report["nodeless"]:
            log.info(
                "ROS topic %s: a publisher without a ROS node (gid %s, e.g. a plain DDS participant) "
                "sends on it: forwarding its messages",
                self.entry.ros,
                gid,
            )
        return report

    def close(self):
        if self.path is not None:
            self.path.close()
        self._close_ros()

    def _close_ros(self):
        pass


def _hint(text):
    if "does not fit the LN capacity" in text:
        return " (raise it with 'capacities' in the bridge configuration)"
    return ""


class LnToRosTopic(_TopicBridge):
    """An LN subscription republished on a ROS topic."""

    direction = "ln_to_ros"

    def __init__(self, node, ln, entry, topic_type):
        from msg_mapping._native import bridge

        super().__init__(entry, topic_type)
        self._node = node
        self.publisher = node.create_publisher(topic_type.msg_class, entry.ros, qos_profile(entry.qos, True))
        settings = entry.ln_port
        try:
            self.path = bridge.LnToRosPath(
                ln.data_client(),
                entry.ln,
                topic_type.ln_name,
                settings.rate,
                settings.buffers,
                settings.reliable_transport,
                topic_type.codec,
                self.publisher.handle.pointer,
            )
        except Exception:
            self._close_ros()
            raise

    def describe(self):
        return "LN topic %s -> ROS %s" % (self.entry.ln, self.entry.ros)

    def _close_ros(self):
        try:
            self._node.destroy_publisher(self.publisher)
        except Exception:
            pass


class RosToLnTopic(_TopicBridge):
    """A ROS subscription written into an LN topic this bridge publishes.

    Loop prevention per publisher: messages from bridge publishers (this bridge's
    and other bridges', loop_prevention.bridge_names on the publisher's node) came
    from LN and are dropped; every other publisher's are forwarded, on the same
    topic. A publisher the ROS graph does not place yet is held (up to the QoS
    depth) until it does, for at most 2 s; one that never gets a node (a plain DDS
    participant) then counts as a non-bridge."""

    direction = "ros_to_ln"

    def __init__(self, node, ln, entry, topic_type, bridge_names):
        from msg_mapping._native import bridge

        super().__init__(entry, topic_type)
        msg_class = topic_type.msg_class
        qos = entry.qos
        self.path = bridge.RosToLnPath(
            ln.data_client(),
            entry.ln,
            topic_type.ln_name,
            entry.ln_port.buffers,
            topic_type.codec,
            node.handle.pointer,
            msg_class._TYPE_SUPPORT,
            entry.ros,
            qos.reliability,
            qos.durability,
            qos.history,
            qos.depth,
            list(bridge_names),
        )

    def describe(self):
        return "ROS topic %s -> LN %s" % (self.entry.ros, self.entry.ln)

    @property
    def ignored(self):
        """Messages not forwarded because a bridge sent them."""
        return self.last["ignored"]
