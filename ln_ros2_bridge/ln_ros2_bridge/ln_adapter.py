"""The one place that knows the two LN Python packages: LN 2.9's and ln_core's.

Both are imported as ``links_and_nodes`` (whichever is on sys.path) and offer
LN 2.9's API, which moves packets through Python objects field by field. The
bridge only needs bytes, so this module reaches for the raw buffers:

* topics: not here -- their packets never pass through Python. The compiled
  data path (msg_mapping._native.bridge) reads and writes them through LN's C
  API on `data_client`: ln_core's own connection (its ``client.handle``), or
  on LN 2.9, whose Python API hides its handle, a second client of the same
  library that the data path opens;
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
LNE_INVALID_REQ_FIELD_FORMAT = 33  # a request the ROS type cannot hold
LNE_SVC_HANDLER_EXC = 36  # anything else that went wrong in the bridge
LNE_NO_PROVIDER_FOUND = 40  # no ROS server behind the bridged service
LNE_SVC_TIMEOUT = 64  # the ROS server did not answer in time


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
        self.client = self.ln.client(client_name, manager_address) if manager_address else self.ln.client(client_name)
        self.name = self.client.name
        self._data_client = None
        self._defined = {}  # definition name -> hash the manager has (ensure_definitions)
        self._closed = False

    def __repr__(self):
        return "<LnConnection %s %r at %s>" % (self.flavor, self.name, self.manager_address)

    # -- topics ---------------------------------------------------------------
    def data_client(self):
        """The msg_mapping bridge.LnClient that topic paths use (made at first use)."""
        if self._data_client is None:
            from msg_mapping._native import bridge

            if self.flavor == "ln_core":
                self._data_client = bridge.LnClient(self._native_module_file(), self.client._native.handle)
            else:
                self._data_client = bridge.LnClient(self._native_module_file(), self.name, self.manager_address or "")
                log.info("LN 2.9: topic data goes through a second LN client, %r", self._data_client.name)
        return self._data_client

    def _native_module_file(self):
        """The LN package's native module (ln_core: links_and_nodes._ln, LN 2.9: _ln):
        the data path uses the libln it links."""
        import sys

        for name in ("links_and_nodes._ln", "_ln"):
            module = sys.modules.get(name)
            if module is not None and getattr(module, "__file__", None):
                return module.__file__
        raise RuntimeError("the native module of %s is not loaded" % self.ln.__name__)

    @property
    def own_names(self):
        """This connection's LN client names (LN 2.9: also the data client's)."""
        names = {self.name}
        if self._data_client is not None:
            names.add(self._data_client.name)
        return names

    # -- services -------------------------------------------------------------
    def service_client(self, name, interface):
        return RawServiceClient(self, name, interface)

    def service_provider(self, name, interface, handler):
        return RawServiceProvider(self, name, interface, handler)

    def put_message_definition(self, name, text):
        return self.client.put_message_definition(name, text)

    def ensure_definitions(self, definitions):
        """Makes the manager know each (name, text, hash) of `definitions` (used ones
        first) that it does not know yet. One it knows with another hash is an error:
        LN programs use that version (e.g. derived from a ROS type with other capacities)."""
        for name, text, md_hash in definitions:
            if self._defined.get(name) == md_hash:
                continue
            try:
                known = self.client.get_message_definition(name)[2]
            except Exception:  # LN's error for a definition it does not have
                known = None
            if known is None:
                self.client.put_message_definition(name, text)
            elif known != md_hash:
                raise ValueError(
                    "the LN manager has another definition of %s (hash %.12s; this bridge derives "
                    "%.12s): LN programs use it with other capacities or from another version of "
                    "the ROS type (use the same capacities, or remove the manager's copy, e.g. "
                    "~/ln_message_definitions/gen/%s of its user, and restart it)" % (name, known, md_hash, name)
                )
            self._defined[name] = md_hash

    # -- manager --------------------------------------------------------------
    def ping(self, timeout=1.0):
        """Raises if the manager is unreachable."""
        self.client.ping(timeout)

    def close(self):
        if self._closed:
            return
        self._closed = True
        if self._data_client is not None:  # its ports are gone by now (the bridge closes paths first)
            self._data_client.close()
            self._data_client = None
        close = getattr(self.client, "close", None)
        if close is not None:  # ln_core; LN 2.9 says goodbye when the object dies
            close()
        self.client = None


class RawServiceClient:
    """Calls an LN service with a flat request; returns the flat response."""

    def __init__(self, conn, name, interface):
        self.name = name
        self.interface = interface
        self._flavor = conn.flavor
        self._lock = threading.Lock()  # one LN service object carries one call at a time
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
            raise LnServiceError(
                "LN service %s: still busy with earlier calls after %.1f s" % (self.name, timeout), LNE_SVC_TIMEOUT
            )
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
                raise LnServiceError(
                    "LN service %s: %s" % (self.name, " ".join(str(error).split())),
                    getattr(error, "code", LNE_REQUEST_FAILED),
                ) from error

    def release(self):
        try:
            self._client.release_service(self._svc)
        except Exception:  # the connection may be gone already
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
            return -abs(error.code)  # LN 2.9 carries only a code back to the caller
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
