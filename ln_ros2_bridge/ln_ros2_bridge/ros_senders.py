"""Which ROS publisher sent a message, so that a ROS->LN bridge drops exactly the
messages of bridge publishers (its own and other bridges') and forwards those of
real ROS publishers on the same topic.

Every rmw fills in the sending publisher's gid (rmw_message_info_t.publisher_gid),
and with Fast DDS it equals the endpoint gid the ROS graph reports for that
publisher (Node.get_publishers_info_by_topic), next to the publisher's node name.
rclpy 7 (Jazzy) leaves the gid out of the message info it gives callbacks (later
rclpy versions add it: ros2/rclpy#1466). So for subscriptions marked with
want_sender(), SenderAwareExecutor takes messages itself, through
rcl_take_serialized_message (ctypes, the librcl rclpy already loaded), with the
info. Where that is not possible (another executor, a library that does not load)
callbacks get rclpy's info without a gid and the bridge falls back to deciding per
topic (see RosToLnTopic).
"""

import ctypes
import logging
import threading
import time
from collections import deque

from rclpy.exceptions import InvalidHandle
from rclpy.executors import MultiThreadedExecutor, await_or_execute

log = logging.getLogger("ln_ros2_bridge.topics")

_WANTS_SENDER = "_ln_ros2_bridge_wants_sender"


def want_sender(subscription):
    """Marks a raw subscription whose callback should get the sender's gid."""
    setattr(subscription, _WANTS_SENDER, True)
    return subscription


def publisher_gid(info):
    """The sending publisher's gid from a callback's message info (ours, or rclpy's
    where it has one), as bytes; None when unknown."""
    gid = info.get("publisher_gid") if isinstance(info, dict) else None
    if isinstance(gid, dict):
        gid = gid.get("data")
    if gid is None:
        return None
    return bytes(gid)


def endpoint_gid(endpoint_info):
    """A TopicEndpointInfo's gid in the form publisher_gid() returns."""
    return bytes(endpoint_info.endpoint_gid)


# ---------------------------------------------------------------------------------------------
# rcl_take_serialized_message with the message info
_RCL_RET_OK = 0
_RCL_RET_SUBSCRIPTION_TAKE_FAILED = 401
_GID_SIZE = 16   # RMW_GID_STORAGE_SIZE of rmw 7 (Jazzy)


class _Allocator(ctypes.Structure):   # rcutils_allocator_t
    _fields_ = [("allocate", ctypes.c_void_p), ("deallocate", ctypes.c_void_p),
                ("reallocate", ctypes.c_void_p), ("zero_allocate", ctypes.c_void_p), ("state", ctypes.c_void_p)]


class _SerializedMessage(ctypes.Structure):   # rcutils_uint8_array_t
    _fields_ = [("buffer", ctypes.POINTER(ctypes.c_uint8)), ("buffer_length", ctypes.c_size_t),
                ("buffer_capacity", ctypes.c_size_t), ("allocator", _Allocator)]


class _Gid(ctypes.Structure):   # rmw_gid_t
    _fields_ = [("implementation_identifier", ctypes.c_char_p), ("data", ctypes.c_uint8 * _GID_SIZE)]


class _MessageInfo(ctypes.Structure):   # rmw_message_info_t
    _fields_ = [("source_timestamp", ctypes.c_int64), ("received_timestamp", ctypes.c_int64),
                ("publication_sequence_number", ctypes.c_uint64), ("reception_sequence_number", ctypes.c_uint64),
                ("publisher_gid", _Gid), ("from_intra_process", ctypes.c_bool)]


def _loaded_library(name):
    """The path of a shared library this process has loaded already (the one rclpy uses)."""
    try:
        with open("/proc/self/maps") as maps:
            for line in maps:
                path = line.rstrip("\n").split(" ")[-1]
                if path.endswith("/" + name):
                    return path
    except OSError:
        pass
    return name


class RclTake:
    """Takes one serialized message with its info from an rcl subscription."""

    def __init__(self):
        self.error = None
        try:
            rcl = ctypes.CDLL(_loaded_library("librcl.so"))
            rcutils = ctypes.CDLL(_loaded_library("librcutils.so"))
            self._take = rcl.rcl_take_serialized_message
            self._take.argtypes = [ctypes.c_void_p, ctypes.POINTER(_SerializedMessage),
                                   ctypes.POINTER(_MessageInfo), ctypes.c_void_p]
            self._take.restype = ctypes.c_int32
            self._init = rcutils.rcutils_uint8_array_init
            self._init.argtypes = [ctypes.POINTER(_SerializedMessage), ctypes.c_size_t, ctypes.POINTER(_Allocator)]
            self._init.restype = ctypes.c_int32
            self._fini = rcutils.rcutils_uint8_array_fini
            self._fini.argtypes = [ctypes.POINTER(_SerializedMessage)]
            self._fini.restype = ctypes.c_int32
            default_allocator = rcutils.rcutils_get_default_allocator
            default_allocator.restype = _Allocator
            self._allocator = default_allocator()
            self._error_string = rcutils.rcutils_get_error_string
            self._error_string.restype = ctypes.c_char * 1024
            self._reset_error = rcutils.rcutils_reset_error
        except (OSError, AttributeError) as error:
            self.error = "cannot use librcl through ctypes: %s" % error

    @property
    def available(self):
        return self.error is None

    def take(self, rcl_subscription):
        """(CDR bytes, info dict with "publisher_gid") or None when there is nothing to take."""
        message = _SerializedMessage()
        if self._init(ctypes.byref(message), 0, ctypes.byref(self._allocator)) != _RCL_RET_OK:
            raise MemoryError("rcutils_uint8_array_init failed")
        try:
            info = _MessageInfo()
            ret = self._take(rcl_subscription, ctypes.byref(message), ctypes.byref(info), None)
            if ret == _RCL_RET_SUBSCRIPTION_TAKE_FAILED:
                return None
            if ret != _RCL_RET_OK:
                text = self._error_string().value.decode(errors="replace")
                self._reset_error()
                raise RuntimeError("rcl_take_serialized_message failed (%d): %s" % (ret, text))
            data = ctypes.string_at(message.buffer, message.buffer_length)
            return data, {"source_timestamp": info.source_timestamp,
                          "received_timestamp": info.received_timestamp,
                          "publication_sequence_number": info.publication_sequence_number,
                          "reception_sequence_number": info.reception_sequence_number,
                          "publisher_gid": bytes(info.publisher_gid.data)}
        finally:
            self._fini(ctypes.byref(message))


_rcl_take = None
_rcl_take_lock = threading.Lock()


def rcl_take():
    """The process's RclTake (made at first use)."""
    global _rcl_take
    if _rcl_take is None:
        with _rcl_take_lock:
            if _rcl_take is None:
                take = RclTake()
                if not take.available:
                    log.warning("%s: ROS->LN loop prevention decides per topic, not per publisher", take.error)
                _rcl_take = take
    return _rcl_take


class SenderAwareExecutor(MultiThreadedExecutor):
    """rclpy's MultiThreadedExecutor, except that subscriptions marked with
    want_sender() are taken with the sending publisher's gid in the message info.
    (Overrides the executor's take step, Executor._take_subscription of rclpy 7.)"""

    def _take_subscription(self, sub):
        take = rcl_take() if getattr(sub, _WANTS_SENDER, False) else None
        if take is None or not take.available or sub.raw is not True:
            return super()._take_subscription(sub)
        try:
            with sub.handle:
                taken = take.take(sub.handle.pointer)
        except InvalidHandle:   # destroyed meanwhile, as rclpy's own take handles it
            return None
        except (RuntimeError, MemoryError) as error:
            log.warning("ROS topic %s: %s; the message is lost", sub.topic_name, error)
            return None
        if taken is None:
            return None

        async def _execute():
            await await_or_execute(sub.callback, *taken)
        return _execute


# ---------------------------------------------------------------------------------------------
# the decision per publisher
class SenderFilter:
    """Decides per sending publisher (gid) whether its messages go to LN: not when the
    publisher belongs to a bridge node (this bridge or another), yes otherwise.

    `endpoints()` returns {gid: node name} for the topic's publishers as the ROS graph
    shows them, with "" for a publisher whose node is not known (yet). A message from
    a publisher the graph does not place yet (discovery still running) is held --
    up to `hold` messages per publisher -- until the graph says, or for at most
    PENDING seconds, after which the publisher counts as a non-bridge: a plain DDS
    participant (no ROS node) never gets a node name.

    Not thread-safe: the caller serialises admit() and resolve()."""

    PENDING = 2.0
    LOOKUP_INTERVAL = 0.05   # seconds between graph look-ups for held publishers

    def __init__(self, topic, endpoints, is_bridge_node, hold=10, clock=time.monotonic):
        self._topic = topic
        self._endpoints = endpoints
        self._is_bridge_node = is_bridge_node
        self._hold = max(1, hold)
        self._clock = clock
        self._verdicts = {}      # gid -> True (forward) / False (a bridge's)
        self._held = {}          # gid -> (first seen, deque of items)
        self._looked_up_at = -1e9
        self.dropped = 0

    def admit(self, gid, item):
        """The items to forward now, in order: `item` and what was held for its sender,
        or nothing (dropped, or held)."""
        verdict = self._verdicts.get(gid)
        if verdict is None:
            self._classify(force=gid not in self._held)
            verdict = self._verdicts.get(gid)
        if verdict is None:
            first_seen, items = self._held.setdefault(gid, (self._clock(), deque(maxlen=self._hold)))
            items.append(item)
            return self._decide_held()
        if not verdict:
            self.dropped += 1
            return []
        return self._decide_held() + [item]

    def resolve(self):
        """The held items that can be forwarded now (called periodically); forgets
        publishers that left the graph."""
        endpoints = self._classify(force=True)
        for gid in [g for g in self._verdicts if g not in endpoints]:
            del self._verdicts[gid]
        return self._decide_held()

    def is_bridge(self, gid):
        return self._verdicts.get(gid) is False

    def _classify(self, force):
        now = self._clock()
        if not force and now - self._looked_up_at < self.LOOKUP_INTERVAL:
            return {}
        self._looked_up_at = now
        endpoints = self._endpoints()
        for gid, node in endpoints.items():
            if node and gid not in self._verdicts:
                self._verdicts[gid] = not self._is_bridge_node(node)
        return endpoints

    def _decide_held(self):
        out = []
        now = self._clock()
        for gid in list(self._held):
            first_seen, items = self._held[gid]
            verdict = self._verdicts.get(gid)
            if verdict is None and now - first_seen >= self.PENDING:
                log.info("ROS topic %s: a publisher without a ROS node (gid %s, e.g. a plain DDS participant) "
                         "sends on it: forwarding its messages", self._topic, gid.hex())
                verdict = self._verdicts[gid] = True
            if verdict is None:
                continue
            del self._held[gid]
            if verdict:
                out.extend(items)
            else:
                self.dropped += len(items)
        return out
