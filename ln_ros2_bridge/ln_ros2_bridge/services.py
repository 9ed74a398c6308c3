"""Service bridges. rclpy has no raw service API, so requests and responses
pass through message objects only at the rclpy boundary (its C serializer),
and through msg_mapping's codecs everywhere else.

Failures never hang a caller: every wait is bounded by the entry's timeout,
and every failure becomes an answer the caller can read -- on ROS the
response's error fields when the type has them, on LN an error code (with
text where the LN package can carry one)."""

import logging
import re
import threading
import time

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.serialization import deserialize_message, serialize_message

from .ln_adapter import (
    LNE_INVALID_REQ_FIELD_FORMAT,
    LNE_NO_PROVIDER_FOUND,
    LNE_SVC_HANDLER_EXC,
    LNE_SVC_TIMEOUT,
    LnServiceError,
)

log = logging.getLogger("ln_ros2_bridge.services")

# Response fields that can carry an error, by the conventions in use (LN's
# generated error_code/error_message, std_srvs' success/message, ...).
_TEXT_FIELDS = ("error_message", "error_text", "error_string", "error", "message", "status_message")
_CODE_FIELDS = ("error_code", "code", "status", "result_code", "return_code")
_FLAG_FIELDS = ("success", "ok")


def fill_error_fields(response, code, text):
    """Writes the error into the response's error fields; False if it has none."""
    fields = response.get_fields_and_field_types()
    found = False
    for name in _TEXT_FIELDS:
        if fields.get(name, "").startswith("string"):
            setattr(response, name, text)
            found = True
            break
    for name in _CODE_FIELDS:
        kind = fields.get(name, "")
        match = re.fullmatch(r"(u?)int(8|16|32|64)", kind)
        if match:
            bits = int(match.group(2)) - (0 if match.group(1) else 1)
            setattr(response, name, min(abs(int(code)) or 1, (1 << bits) - 1))  # never 0: 0 means success
            found = True
            break
    for name in _FLAG_FIELDS:
        if fields.get(name) == "boolean":
            setattr(response, name, False)
            found = True
            break
    return found


class _BridgedService:
    """What both directions of a bridged service keep: the entry, its types, the counters."""

    def __init__(self, node, entry, service_type):
        self.entry = entry
        self.service_type = service_type
        self.count = 0  # calls answered
        self.errors = 0  # calls that failed
        self._node = node


class LnToRosService(_BridgedService):
    """A ROS service server that calls the LN service."""

    direction = "ln_to_ros"

    def __init__(self, node, ln, entry, service_type):
        super().__init__(node, entry, service_type)
        self._response_class = service_type.srv_class.Response
        self._ln_service = ln.service_client(entry.ln, service_type.ln_name)
        self.server = node.create_service(
            service_type.srv_class, entry.ros, self._handle, callback_group=ReentrantCallbackGroup()
        )

    def _handle(self, request, response):
        types = self.service_type
        try:
            try:
                flat = types.request.cdr_to_ln(serialize_message(request))
            except Exception as error:
                raise LnServiceError(
                    "the request does not fit LN's %s: %s" % (types.ln_name, error), LNE_INVALID_REQ_FIELD_FORMAT
                ) from error
            answer = self._ln_service.call(flat, self.entry.timeout)
            result = deserialize_message(types.response.ln_to_cdr(answer), self._response_class)
            self.count += 1
            return result
        except Exception as error:
            self.errors += 1
            code = getattr(error, "code", LNE_SVC_HANDLER_EXC)
            text = "ln_ros2_bridge: LN service %s failed: %s" % (self.entry.ln, error)
            if not fill_error_fields(response, code, text):
                log.error(
                    "%s (answering %s with a default response: its type has no error fields)", text, self.entry.ros
                )
            else:
                log.warning(text)
            return response

    def close(self):
        try:
            self._node.destroy_service(self.server)
        except Exception:
            pass
        self._ln_service.release()


class RosToLnService(_BridgedService):
    """An LN service provider that calls the ROS service."""

    direction = "ros_to_ln"

    def __init__(self, node, ln, entry, service_type):
        super().__init__(node, entry, service_type)
        self._request_class = service_type.srv_class.Request
        self.client = node.create_client(service_type.srv_class, entry.ros, callback_group=ReentrantCallbackGroup())
        self._provider = ln.service_provider(entry.ln, service_type.ln_name, self._handle)

    def _handle(self, flat):
        """Runs in the provider's LN thread; the ROS executor completes the future."""
        types = self.service_type
        deadline = time.monotonic() + self.entry.timeout
        # A server that DDS has not discovered yet is waited for, within the
        # call's timeout: LN callers are often faster than discovery.
        if not self.client.service_is_ready() and not self.client.wait_for_service(timeout_sec=self.entry.timeout):
            self.errors += 1
            raise LnServiceError("ln_ros2_bridge: no ROS server for %s" % self.entry.ros, LNE_NO_PROVIDER_FOUND)
        try:
            request = deserialize_message(types.request.ln_to_cdr(flat), self._request_class)
        except Exception as error:
            self.errors += 1
            raise LnServiceError(
                "ln_ros2_bridge: cannot convert the request for %s: %s" % (self.entry.ros, error),
                LNE_INVALID_REQ_FIELD_FORMAT,
            ) from error
        done = threading.Event()
        future = self.client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(max(0.0, deadline - time.monotonic())):
            self.client.remove_pending_request(future)
            self.errors += 1
            raise LnServiceError(
                "ln_ros2_bridge: ROS service %s did not answer within %.1f s" % (self.entry.ros, self.entry.timeout),
                LNE_SVC_TIMEOUT,
            )
        try:
            answer = types.response.cdr_to_ln(serialize_message(future.result()))
        except Exception as error:
            self.errors += 1
            raise LnServiceError(
                "ln_ros2_bridge: the response of %s does not fit LN's %s: %s" % (self.entry.ros, types.ln_name, error),
                LNE_SVC_HANDLER_EXC,
            ) from error
        self.count += 1
        return answer

    def close(self):
        self._provider.close()
        try:
            self._node.destroy_client(self.client)
        except Exception:
            pass
