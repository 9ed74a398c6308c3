"""Service callers and providers (LN 2.9's service_wrapper)."""

import logging
import threading
import traceback

from . import _ln
from ._errors import LNError, LNE_SVC_HANDLER_EXC, LNE_SVC_REQ_NOT_RUNNING, LNE_SVC_REQ_RUNNING, LNE_SVC_RESP_LATER
from ._packets import ln29_definition

log = logging.getLogger("links_and_nodes")

#: Handler return value: the response follows later (request.respond() from anywhere).
SVC_RESP_LATER = -LNE_SVC_RESP_LATER


class request_wrapper:
    """The request a provider's handler is answering."""
    __slots__ = ("service", "request", "name")

    def __init__(self, service, request):
        self.service = service
        self.request = request
        self.name = service.name

    def respond(self):
        """Sends the service's `resp` as the response (once)."""
        self.request.respond(self.service.resp._flat())

    def respond_error(self, error_code, message=""):
        """ln_core: fails the call with an error code (> 0 the application's)
        and a message the caller sees in its LNError."""
        self.request.respond_error(int(error_code), str(message))

    def is_aborted(self):
        return self.request.is_aborted()

    def abort(self):
        self.request.respond_error(-39, "aborted by the provider")


class service_wrapper:
    """A service handle: `req` and `resp` are messages whose fields are
    attributes. Callers fill `req` (or pass fields as keyword arguments) and
    call(); providers set a handler and register."""

    def __init__(self, clnt, name, interface, definition, signature, is_provider=False):
        self.name = name
        self.interface = interface
        self.signature = signature
        self.clnt = clnt
        self.lock = threading.RLock()
        self._is_provider = is_provider
        self._model = model = clnt._model(interface, definition)
        if model["kind"] != "service":
            raise LNError("'%s' is not a service definition" % interface, 53, 0)
        self.definition = ln29_definition(model)
        self.defines = self.definition["defines"]
        self._req_fields = self.definition["fields"]
        self._resp_fields = self.definition["resp_fields"]
        self._req_class = clnt._compiler.part_class(model, "fields", "::request", service=True)
        self._resp_class = clnt._compiler.part_class(model, "response_fields", "::response", service=True)
        self.req = self._req_class(name=name + ".req")
        self.resp = self._resp_class(name=name + ".resp")
        self._native = _ln.Service(clnt._native, name, interface, signature)
        self.cb = None
        self.async_req = None
        self._async_done = None

    def __repr__(self):
        return "<links_and_nodes.service %r (%s)%s>" % (self.name, self.interface,
                                                       " provider" if self._is_provider else "")

    # -- calling ----------------------------------------------------------
    def __call__(self, *args, **kwargs):
        if not (args or kwargs):  # the request is in `req` already: the shortest path
            with self.lock:
                return self._call(0.0)
        timeout = kwargs.pop("_timeout", 0) if "_timeout" in kwargs else 0
        is_async = kwargs.pop("is_async", kwargs.pop("async", False)) if kwargs else False
        with self.lock:
            if args or kwargs:
                self._fill_request(args, kwargs)
            if is_async:
                return self._start_async()
            return self._call(float(timeout or 0))

    def _call(self, timeout):
        resp = self.resp
        flat = self._native.call(self.req._flat(), timeout, resp._buf if resp._fixed else None)
        if flat is not None:
            resp._decode(flat)
        return self

    def _fill_request(self, args, kwargs):
        req = self.req
        if args:
            if len(args) > len(req._fields):
                raise TypeError("service '%s' takes at most %d request fields" % (self.name, len(req._fields)))
            kwargs = dict(zip(req._fields, args), **kwargs)
        types = req._field_types
        for key, value in kwargs.items():
            if key not in types:
                raise AttributeError("service '%s' (%s) has no request field '%s'; fields: %s"
                                     % (self.name, self.interface, key, ", ".join(req._fields)))
            setattr(req, key, value)

    def call(self, *args, **kwargs):
        """Blocking call: fields as keyword arguments (or set on `req`); returns
        self with `resp` filled. Raises LNError on failure."""
        if not (args or kwargs):
            with self.lock:
                return self._call(0.0)
        return self(*args, **kwargs)

    def call_with_timeout(self, *args, **kwargs):
        """call() giving up after `timeout` seconds (keyword; 0: no limit)."""
        timeout = kwargs.pop("timeout", 0)
        return self(*args, _timeout=timeout, **kwargs)

    def abort(self):
        """Aborts a call() running in another thread."""
        self._native.abort()

    def call_async(self, *args, **kwargs):
        """Starts a call and returns at once; poll finished()."""
        kwargs["is_async"] = True
        return self(*args, **kwargs)

    def _start_async(self):
        if self.async_req is not None and self._async_done is None:
            raise LNError("async request for service %r already running!" % self.name, LNE_SVC_REQ_RUNNING, 0)
        self._native.start_async(self.req._flat())
        self.async_req = self
        self._async_done = None
        return self

    def finished(self, timeout=0):
        """True once the asynchronous call finished (then `resp` is filled);
        raises LNError if it failed."""
        if self.async_req is None:
            raise LNError("error, there is no async request pending!", LNE_SVC_REQ_NOT_RUNNING, 0)
        if self._async_done is not None:
            if isinstance(self._async_done, BaseException):
                raise self._async_done
            return True
        try:
            flat = self._native.poll_async(float(timeout))
        except LNError as error:
            self._async_done = error
            raise
        if flat is None:
            return False
        self.resp._decode(flat)
        self._async_done = True
        return True

    def abort_async(self):
        if self.async_req is None:
            raise LNError("error, there is no async request pending!", LNE_SVC_REQ_NOT_RUNNING, 0)
        self._native.abort_async()
        self.async_req = None

    def call_future(self, *args, **kwargs):
        """ln_core: starts an asynchronous call and returns a ServiceFuture."""
        self.call_async(*args, **kwargs)
        return ServiceFuture(self)

    # -- providing --------------------------------------------------------
    def set_handler(self, cb, *cb_args):
        """cb(request, req, resp, *cb_args) -> int, called for each request:
        fill `resp`, call request.respond(), return 0 (or an error code > 0)."""
        self.cb = cb, cb_args
        self._native.set_handler(self._handler, self.req._buf if self.req._fixed else None)

    def do_register(self, group_name=None):
        """Registers the provider (in a service group; None: the default group)."""
        if self.cb is None:
            raise LNError("service %r: set_handler() before do_register()" % self.name, 35, 0)
        self._native.register(group_name)

    def get_fd(self):
        return self._native.get_fd()

    def utf8_decode_char_fields(self, do_decode):
        """Accepted for LN 2.9 compatibility; text is always decoded."""

    def _handler(self, native_request, prefilled=False):
        request = request_wrapper(self, native_request)
        if not prefilled:
            try:
                self.req._decode(native_request.data())
            except Exception as error:
                log.error("service %s: cannot unpack request: %s", self.name, error)
                native_request.respond_error(-29, "cannot unpack the request: %s" % error)
                return 0
        try:
            ret = self.cb[0](request, self.req, self.resp, *self.cb[1])
        except Exception as error:
            log.error("error in service handler %s of %s:\n%s", self.cb[0], self.name, traceback.format_exc())
            if not native_request.responded:
                native_request.respond_error(-LNE_SVC_HANDLER_EXC, "%s: %s" % (type(error).__name__, error))
                return 0
            return -LNE_SVC_HANDLER_EXC
        if ret is None:
            return 0
        return int(ret)

    def respond(self, request):
        req = request.request if isinstance(request, request_wrapper) else request
        req.respond(self.resp._flat())


class ServiceFuture:
    """ln_core: an asynchronous service call (service_wrapper.call_future())."""

    def __init__(self, svc):
        self._svc = svc

    def done(self):
        try:
            return self._svc.finished()
        except LNError:
            return True

    def result(self, timeout=None):
        """Waits (at most `timeout` seconds, None: no limit) and returns the
        service's `resp`; raises LNError if the call failed, TimeoutError if
        it is still running."""
        if not self._svc.finished(-1 if timeout is None else float(timeout)):
            raise TimeoutError("service %r: no response within %s s" % (self._svc.name, timeout))
        return self._svc.resp

    def exception(self, timeout=None):
        try:
            self.result(timeout)
        except LNError as error:
            return error
        return None

    def cancel(self):
        self._svc.abort_async()
        return True
