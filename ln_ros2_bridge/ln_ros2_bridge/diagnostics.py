"""The bridge on /diagnostics (diagnostic_msgs/msg/DiagnosticArray, once a
second, as ROS tools expect): one status per configured or automatic entry --

* OK: running; values: rate (messages/s over the last period), forwarded,
  dropped (not delivered: conversion or publish failures, LN packets the port
  skipped, gaps in a ROS publisher's sequence), ignored (from bridge publishers:
  loop prevention), types, QoS;
* WARN: running, but it dropped messages in the last period (the message says
  why);
* ERROR: it does not run, and why (unknown type, name taken, ...);

and one status for the LN connection."""

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


class Diagnostics:
    PERIOD = 1.0

    def __init__(self, node):
        self._node = node
        self._publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._name = node.get_name()
        self._published_at = 0.0
        self._previous = {}  # entry key -> (time, forwarded, dropped) at the last publication

    def update(self, bridge, reports):
        """Publishes when PERIOD has passed. `reports`: topic key -> its path's report
        (read just now)."""
        now = time.monotonic()
        if now - self._published_at < self.PERIOD:
            return
        self._published_at = now
        message = DiagnosticArray()
        message.header.stamp = self._node.get_clock().now().to_msg()
        message.status = [self._connection(bridge)]
        previous, self._previous = self._previous, {}
        for key, running in sorted(bridge.active.items()):
            message.status.append(self._running(key, running, reports.get(key), previous.get(key), now))
        for key, (entry, why) in sorted(bridge.failed_entries().items()):
            message.status.append(self._status(key, entry, ERROR, why, []))
        self._publisher.publish(message)

    def close(self):
        try:
            self._node.destroy_publisher(self._publisher)
        except Exception:
            pass

    def _connection(self, bridge):
        ln = bridge.ln
        status = DiagnosticStatus(name="%s: LN connection" % self._name, hardware_id=self._hardware_id(bridge))
        if ln is None:
            status.level, status.message = ERROR, "not connected to the LN manager"
        else:
            status.level, status.message = OK, "connected as %s (%s)" % (", ".join(sorted(ln.own_names)), ln.flavor)
        status.values = [KeyValue(key="manager", value=str(bridge.config.ln_manager or ""))]
        return status

    def _running(self, key, running, report, previous, now):
        entry = running.entry
        if report is not None:  # a topic: the compiled path's counters
            forwarded = report["forwarded"]
            dropped = report["errors"] + report["lost"]
            extra = [
                ("received", report["received"]),
                ("ignored (from bridges)", report["ignored"]),
                ("held (publisher not known yet)", report["held"]),
            ]
        else:  # a service: calls
            forwarded, dropped, extra = running.count, running.errors, []
        rate = new_drops = 0
        if previous is not None:
            then, forwarded_then, dropped_then = previous
            rate = (forwarded - forwarded_then) / max(1e-9, now - then)
            new_drops = dropped - dropped_then
        self._previous[key] = (now, forwarded, dropped)
        types = running.topic_type if key[0] == "topic" else running.service_type
        values = (
            [("rate", "%.1f" % rate), ("forwarded", forwarded), ("dropped", dropped)]
            + extra
            + [("ln type", types.ln_name), ("ros type", types.ros_type)]
        )
        if key[0] == "topic":
            qos = entry.qos
            values.append(("qos", "%s, %s, %s %d" % (qos.reliability, qos.durability, qos.history, qos.depth)))
        if new_drops:
            level, text = WARN, "dropped %d in the last %.0f s" % (new_drops, self.PERIOD)
        else:
            level, text = OK, "running"
        return self._status(key, entry, level, text, values)

    def _status(self, key, entry, level, message, values):
        arrow = "->" if entry.direction == "ln_to_ros" else "<-"
        status = DiagnosticStatus(
            level=level, message=message, name="%s: %s %s %s %s" % (self._name, key[0], entry.ln, arrow, entry.ros)
        )
        status.values = [
            KeyValue(key=k, value=str(v))
            for k, v in [("direction", entry.direction), ("ln", entry.ln), ("ros", entry.ros), ("origin", entry.origin)]
            + list(values)
        ]
        return status

    @staticmethod
    def _hardware_id(bridge):
        return "LN %s" % (bridge.config.ln_manager or "$LN_MANAGER")
