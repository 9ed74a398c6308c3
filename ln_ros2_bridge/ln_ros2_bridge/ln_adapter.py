"""The one place that knows the two LN Python packages: LN 2.9's and ln_core's.

Both are imported as ``links_and_nodes`` (whichever is on sys.path) and offer
LN 2.9's API, which moves packets through Python objects field by field. The
bridge only needs bytes, so this module reaches for the raw buffers:

* topics: the port's packet buffer (a bytearray the native read/write use
  directly); ln_core's ``read_bytes``/``write_bytes`` when present;
* services (LN's flat wire format: fields in order, a dynamic field as u32
  count + elements): ln_core's native ``call(flat)`` / ``request.data()`` /
  ``respond(flat)``; on LN 2.9 the wrapper's field list is replaced by one
  raw ``uint8_t*`` field, so its C++ packer sends our bytes unchanged, and its
  unpack hook hands us the received bytes (valid only during that hook);
* the manager's list of topics and services (see ln_introspection.py).

Everything else in the bridge uses only the classes below.
"""

import importlib
import logging
import threading
import time

import numpy as np

log = logging.getLogger("ln_ros2_bridge.ln")

# LN error codes (values of LN's enum ln_error_t) the bridge answers LN callers with.
LNE_REQUEST_FAILED = 11
LNE_INVALID_REQ_FIELD_FORMAT = 33   # a request the ROS type cannot hold
LNE_SVC_HANDLER_EXC = 36            # anything else that went wrong in the bridge
LNE_NO_PROVIDER_FOUND = 40          # no ROS server behind the bridged service
LNE_SVC_TIMEOUT = 64                # the ROS server did not answer in time


class LnServiceError(Exception):
    """A failed LN service call, or the error an LN provider answers with."""

    def __init__(self, message, code=LNE_SVC_HANDLER_EXC):
        super().__init__(message)
        self.code = code


def _raw_field():
    # A field list entry as LN 2.9's packer expects it after its own preparation:
    # [type, name, count, base type, is_pointer, is_primitive, primitive name].
    return [["uint8_t*", "raw", 1, "uint8_t", True, True, "uint8_t"]]


class _RawPart:
    """Stands in for LN 2.9's request/response object: one raw byte field."""

    def __init__(self):
        self.raw = np.zeros(0, np.uint8)
        self.raw_len = 0

    def set(self, data):
        self.raw = np.frombuffer(bytes(data), np.uint8)
        self.raw_len = len(self.raw)


class LnConnection:
    """A client of one LN manager, through whichever links_and_nodes is importable."""

    def __init__(self, client_name, manager_address=None, module_name="links_and_nodes"):
        self.ln = importlib.import_module(module_name)
        # LN 2.9's package has ln_wrappers; ln_core's has the native _ln.Client.
        self.flavor = "ln29" if hasattr(self.ln, "ln_wrappers") else "ln_core"
        self.manager_address = manager_address
        self.client = self.ln.client(client_name, manager_address) if manager_address \
            else self.ln.client(client_name)
        self.name = self.client.name
        self._closed = False

    def __repr__(self):
        return "<LnConnection %s %r at %s>" % (self.flavor, self.name, self.manager_address)

    # -- topics -------------------------------------------------------------
    def subscribe(self, topic, md_name, rate=-1, buffers=1, reliable=False):
        port = self.client.subscribe(topic, md_name, rate=rate, buffers=buffers,
                                     need_reliable_transport=reliable)
        return RawInPort(port, self.flavor)

    def publish(self, topic, md_name, buffers=1):
        return RawOutPort(self.client.publish(topic, md_name, buffers), self.flavor)

    def unsubscribe(self, port):
        self.client.unsubscribe(port.port)

    def unpublish(self, port):
        self.client.unpublish(port.port)

    # -- services -------------------------------------------------------------
    def service_client(self, name, interface):
        return RawServiceClient(self, name, interface)

    def service_provider(self, name, interface, handler):
        return RawServiceProvider(self, name, interface, handler)

    def put_message_definition(self, name, text):
        return self.client.put_message_definition(name, text)

    # -- manager --------------------------------------------------------------
    def ping(self, timeout=1.0):
        """Raises if the manager is unreachable."""
        self.client.ping(timeout)

    def close(self):
        if self._closed:
            return
        self._closed = True
        close = getattr(self.client, "close", None)
        if close is not None:  # ln_core; LN 2.9 says goodbye when the object dies
            close()
        self.client = None


class RawInPort:
    """An LN subscription read as bytes."""

    def __init__(self, port, flavor):
        self.port = port
        self.flavor = flavor
        self._native = port.port
        # The packet's own buffer, which the native read fills in place (no copy, no
        # allocation per packet); ln_core's read_bytes() when a future package hides it.
        self._buffer = getattr(port.packet, "_data" if flavor == "ln29" else "_buf", None)
        self._read_bytes = getattr(port, "read_bytes", None) if self._buffer is None else None

    @property
    def size(self):
        return len(self._buffer) if self._buffer is not None else int(self._native.message_size)

    def read(self, timeout):
        """The next packet's bytes (a buffer valid until the next read), or None.
        timeout in seconds; the GIL is released while waiting."""
        if self._buffer is None:
            return self._read_bytes(timeout)
        return self._buffer if self._native.read(self._buffer, float(timeout)) else None

    @property
    def timestamp(self):
        return self._native.timestamp

    def has_publisher(self):
        return self.port.has_publisher()

    def unblock(self):
        self.port.unblock()


class RawOutPort:
    """An LN publication written from bytes. `buffer` is the packet buffer:
    codecs write into it directly, then write() sends it."""

    def __init__(self, port, flavor):
        self.port = port
        self.flavor = flavor
        self._native = port.port
        self.buffer = port.packet._data if flavor == "ln29" else port.packet._buf

    def write(self, timestamp=None):
        if self.flavor == "ln29":
            if timestamp is None:
                self._native.write(self.buffer)
            else:
                self._native.write_ts(self.buffer, float(timestamp))
        else:
            self._native.write(self.buffer, timestamp)

    def write_bytes(self, data, timestamp=None):
        self.buffer[:] = data
        self.write(timestamp)

    def has_subscriber(self):
        return self.port.has_subscriber()


class RawServiceClient:
    """Calls an LN service with a flat request; returns the flat response."""

    def __init__(self, conn, name, interface):
        self.name = name
        self.interface = interface
        self._flavor = conn.flavor
        self._lock = threading.Lock()   # one LN service object carries one call at a time
        self._client = conn.client
        self._svc = conn.client.get_service(name, interface)
        if self._flavor == "ln29":
            svc = self._svc
            svc.req = _RawPart()
            svc._req_fields = _raw_field()
            self._response = None

            def capture_response(fields_and_def=None):
                # Called by LN 2.9's C++ while _response_buffer views the response.
                self._response = bytes(svc._response_buffer)
            svc._unpack_response = capture_response

    def call(self, flat, timeout):
        """timeout in seconds (> 0), for the wait for earlier calls and for this one.
        Raises LnServiceError."""
        start = time.monotonic()
        if not self._lock.acquire(timeout=timeout):
            raise LnServiceError("LN service %s: still busy with earlier calls after %.1f s" % (self.name, timeout),
                                 LNE_SVC_TIMEOUT)
        timeout = max(0.001, timeout - (time.monotonic() - start))
        with _Unlock(self._lock):
            try:
                if self._flavor == "ln29":
                    self._svc.req.set(flat)
                    self._response = None
                    self._svc.svc.call(self._svc, float(timeout))
                    if self._response is None:
                        raise LnServiceError("no response data")
                    return self._response
                return bytes(self._svc._native.call(bytes(flat), float(timeout)))
            except LnServiceError:
                raise
            except Exception as error:  # LN raises its own exception types
                # LN's texts span lines; one line reads better in logs and error fields
                raise LnServiceError("LN service %s: %s" % (self.name, " ".join(str(error).split())),
                                     getattr(error, "code", LNE_REQUEST_FAILED)) from error

    def release(self):
        try:
            self._client.release_service(self._svc)
        except Exception:   # the connection may be gone already
            pass
        self._svc = None


class _Unlock:
    """Releases an already acquired lock at the end of a with-block."""

    def __init__(self, lock):
        self._lock = lock

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._lock.release()


class RawServiceProvider:
    """Provides an LN service; handler(flat_request: bytes) -> flat response bytes,
    or raises LnServiceError (answered as an LN error where LN can carry one).

    Requests are handled in a thread of our own, one service group per
    provider, so a slow peer behind one service never stalls another."""

    def __init__(self, conn, name, interface, handler, error_response=None):
        self.name = name
        self.interface = interface
        self._conn = conn
        self._handler = handler
        self._flavor = conn.flavor
        self._group = "ln_ros2_bridge:" + name
        self._stop = threading.Event()
        svc = self._svc = conn.client.get_service_provider(name, interface)
        if self._flavor == "ln29":
            svc.resp = _RawPart()
            svc._resp_fields = _raw_field()
            svc._handler = self._ln29_handler
            svc.do_register(self._group)
        else:
            svc._native.set_handler(self._ln_core_handler)
            svc._native.register(self._group)
        self._thread = threading.Thread(target=self._serve, name="ln-provider " + name, daemon=True)
        self._thread.start()

    def _serve(self):
        while not self._stop.is_set():
            try:
                self._conn.client.wait_and_handle_service_group_requests(self._group, 0.2)
            except Exception as error:
                if self._stop.is_set():
                    break
                log.warning("LN provider %s: %s", self.name, error)
                self._stop.wait(0.5)  # the connection is likely gone; the bridge will rebuild it

    def _ln29_handler(self, request):
        # LN 2.9 calls this with _response_buffer viewing the request bytes.
        flat = bytes(self._svc._response_buffer)
        try:
            response = self._handler(flat)
        except LnServiceError as error:
            log.warning("LN service %s: answering error %d: %s", self.name, error.code, error)
            return -abs(error.code)   # LN 2.9 carries only a code back to the caller
        self._svc.resp.set(response)
        request.respondv(self._svc)
        return 0

    def _ln_core_handler(self, native_request, _prefilled=False):
        # The native module passes (request, prefilled); prefilled concerns
        # only its own request buffer, which the bridge does not use.
        try:
            response = self._handler(bytes(native_request.data()))
        except LnServiceError as error:
            native_request.respond_error(int(error.code), str(error))
            return 0
        native_request.respond(response)
        return 0

    def close(self):
        self._stop.set()
        try:
            self._conn.client.unblock_service_group(self._group)
        except Exception:
            pass
        self._thread.join(timeout=2.0)
        try:
            self._conn.client.release_service(self._svc)
        except Exception:
            pass
        self._svc = None
