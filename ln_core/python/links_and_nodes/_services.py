"""Service callers and providers (LN 2.9's service_wrapper)."""

from __future__ import annotations

import logging
import threading
import traceback
import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, SupportsInt

from . import _ln
from ._errors import (
    LNE_SVC_HANDLER_EXC,
    LNE_SVC_REQ_NOT_RUNNING,
    LNE_SVC_REQ_RUNNING,
    LNE_SVC_RESP_LATER,
    LNE_SVC_TIMEOUT,
    LNError,
)
from ._mainloop import MainloopInterface, default_glib_mainloop, wait_until
from ._packets import ln29_definition

if TYPE_CHECKING:
    from ._client import client
    from ._packets import Part

log = logging.getLogger("links_and_nodes")

#: Handler return value: the response follows later (request.respond() from anywhere).
SVC_RESP_LATER = -LNE_SVC_RESP_LATER


class request_wrapper:
    """The request a provider's handler is answering."""

    __slots__ = ("service", "request", "name")

    def __init__(self, service: service_wrapper, request: _ln.Request) -> None:
        self.service = service
        self.request = request
        self.name = service.name

    def respond(self) -> None:
        """Sends the service's `resp` as the response (once)."""
        self.request.respond(self.service.resp._flat())

    def respond_error(self, error_code: SupportsInt, message: object = "") -> None:
        """ln_core: fails the call with an error code (> 0 the application's)
        and a message the caller sees in its LNError."""
        self.request.respond_error(int(error_code), str(message))

    def is_aborted(self) -> bool:
        return self.request.is_aborted()

    def abort(self) -> None:
        self.request.respond_error(-39, "aborted by the provider")


class service_wrapper:
    """A service handle: `req` and `resp` are messages whose fields are
    attributes. Callers fill `req` (or pass fields as keyword arguments) and
    call(); providers set a handler and register."""

    # Set by mainloop_on_async_finish(): (loop, source id) of the finish watch.
    _finish_watch: tuple[MainloopInterface, Any] | None

    def __init__(
        self,
        clnt: client,
        name: str,
        interface: str,
        definition: str,
        signature: str,
        is_provider: bool = False,
        mainloop: MainloopInterface | None = None,
    ) -> None:
        if mainloop is not None and not isinstance(mainloop, MainloopInterface):
            raise TypeError(
                "mainloop must be a links_and_nodes.MainloopInterface (e.g. ln.SelectMainloop() or "
                "ln.GLibMainloop()), not %r" % (mainloop,)
            )
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
        self._req_class: type[Part] = clnt._compiler.part_class(model, "fields", "::request", service=True)
        self._resp_class: type[Part] = clnt._compiler.part_class(model, "response_fields", "::response", service=True)
        # Messages whose fields are created at run time from the definition.
        self.req: Any = self._req_class(name=name + ".req")
        self.resp: Any = self._resp_class(name=name + ".resp")
        self._native = _ln.Service(clnt._native, name, interface, signature)
        self.cb: tuple[Callable[..., SupportsInt | None], tuple[Any, ...]] | None = None
        self.async_req: service_wrapper | None = None
        self._async_done: bool | BaseException | None = None
        self._mainloop = mainloop
        self._loop_sources: list[tuple[MainloopInterface, Any]] = []  # (loop, source id) of do_register_with_mainloop

    def __repr__(self) -> str:
        return "<links_and_nodes.service %r (%s)%s>" % (
            self.name,
            self.interface,
            " provider" if self._is_provider else "",
        )

    # -- calling ----------------------------------------------------------
    def __call__(self, *args: Any, **kwargs: Any) -> service_wrapper:
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
                raise AttributeError(
                    "service '%s' (%s) has no request field '%s'; fields: %s"
                    % (self.name, self.interface, key, ", ".join(req._fields))
                )
            setattr(req, key, value)

    def call(self, *args: Any, **kwargs: Any) -> service_wrapper:
        """Blocking call: fields as keyword arguments (or set on `req`); returns
        self with `resp` filled. Raises LNError on failure. A service got with
        mainloop= runs its loop meanwhile (call_via_mainloop())."""
        if self._mainloop is not None:
            return self.call_via_mainloop(*args, **kwargs)
        if not (args or kwargs):
            with self.lock:
                return self._call(0.0)
        return self(*args, **kwargs)

    def call_with_timeout(self, *args: Any, **kwargs: Any) -> service_wrapper:
        """call() giving up after `timeout` seconds (keyword; 0: no limit)."""
        timeout = kwargs.pop("timeout", 0)
        if self._mainloop is not None:
            return self.call_via_mainloop(*args, _timeout=timeout, **kwargs)
        return self(*args, _timeout=timeout, **kwargs)

    def abort(self) -> None:
        """Aborts a call() running in another thread."""
        self._native.abort()

    def call_async(self, *args: Any, **kwargs: Any) -> service_wrapper:
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

    def finished(self, timeout: float = 0) -> bool:
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

    def abort_async(self) -> None:
        if self.async_req is None:
            raise LNError("error, there is no async request pending!", LNE_SVC_REQ_NOT_RUNNING, 0)
        self._native.abort_async()
        self.async_req = None

    def get_finished_notification_fd(self) -> int:
        """A descriptor that becomes readable when the running asynchronous
        call finished (LN 2.9 has it on `async_req`, which is this object)."""
        return self._native.async_notification_fd()

    # -- main loops (LN 2.9's mainloop= integration) ------------------------
    def call_via_mainloop(self, *args: Any, **kwargs: Any) -> service_wrapper:
        """call(), running the main loop (`_mainloop`, default the service's)
        until the response is there; `_timeout` (or `timeout`) in seconds,
        0 or None: no limit. A call of the same service from a callback of
        the loop waits for the running one."""
        loop = kwargs.pop("_mainloop", None) or self._mainloop
        if loop is None:
            raise TypeError(
                "call_via_mainloop(): service %r has no main loop; pass _mainloop= or get the "
                "service with mainloop=" % self.name
            )
        timeout = kwargs.pop("_timeout", None) if "_timeout" in kwargs else kwargs.pop("timeout", None)
        while not self.lock.acquire(blocking=False):
            loop.iterate(True)
        try:
            wait_until(loop, lambda: self.async_req is None or self._async_done is not None)
            self.call_async(*args, **kwargs)
            finished: list[bool] = []
            self.mainloop_on_async_finish(loop, finished.append, True)
            if not wait_until(loop, lambda: finished, timeout or None):
                self._remove_finish_watch()
                self.abort_async()
                raise LNError("service call %s timed out (timeout: %.1fs)" % (self.name, timeout), LNE_SVC_TIMEOUT, 0)
            if isinstance(self._async_done, BaseException):
                raise self._async_done
            return self
        finally:
            self.lock.release()

    def mainloop_on_async_finish(
        self, loop: MainloopInterface, handler: Callable[..., object], *args: Any, **kwargs: Any
    ) -> None:
        """Calls handler(*args, **kwargs) from `loop` once the running
        asynchronous call finished (`resp` filled, or finished() raises)."""
        if self.async_req is None:
            raise LNError("error, there is no async request pending!", LNE_SVC_REQ_NOT_RUNNING, 0)
        fd = self.get_finished_notification_fd()

        def on_finished():
            try:
                if not self.finished():
                    return True  # not yet: keep watching
            except LNError:
                pass  # finished() raises it again for the caller
            self._finish_watch = None
            try:
                handler(*args, **kwargs)
            except Exception:
                log.error(
                    "error in the async-finish handler %r of service %s:\n%s",
                    handler,
                    self.name,
                    traceback.format_exc(),
                )
            return False

        self._finish_watch = (loop, loop.fd_add(fd, "in", on_finished))

    def _remove_finish_watch(self):
        watch = getattr(self, "_finish_watch", None)
        if watch is not None:
            watch[0].source_remove(watch[1])
            self._finish_watch = None

    def call_gobject(self, *args: Any, **kwargs: Any) -> service_wrapper:
        """Deprecated in LN 2.9 (PyGTK): call_via_mainloop() on GLib's default context."""
        warnings.warn("call_gobject() is deprecated: use call_via_mainloop()", DeprecationWarning, stacklevel=2)
        return self.call_via_mainloop(*args, _mainloop=default_glib_mainloop(), **kwargs)

    def gobject_on_async_finish(self, handler: Callable[..., object], *args: Any, **kwargs: Any) -> None:
        """Deprecated in LN 2.9 (PyGTK): mainloop_on_async_finish() on GLib's default context."""
        warnings.warn(
            "gobject_on_async_finish() is deprecated: use mainloop_on_async_finish()", DeprecationWarning, stacklevel=2
        )
        return self.mainloop_on_async_finish(default_glib_mainloop(), handler, *args, **kwargs)

    def call_future(self, *args: Any, **kwargs: Any) -> ServiceFuture:
        """ln_core: starts an asynchronous call and returns a ServiceFuture."""
        self.call_async(*args, **kwargs)
        return ServiceFuture(self)

    # -- providing --------------------------------------------------------
    def set_handler(self, cb: Callable[..., SupportsInt | None], *cb_args: Any) -> None:
        """cb(request, req, resp, *cb_args) -> int, called for each request:
        fill `resp`, call request.respond(), return 0 (or an error code > 0)."""
        self.cb = cb, cb_args
        self._native.set_handler(self._handler, self.req._buf if self.req._fixed else None)

    def do_register(self, group_name: str | None = None) -> None:
        """Registers the provider (in a service group; None: the default
        group). With a main loop (mainloop=), the loop handles the group."""
        if self._mainloop is not None:
            return self.do_register_with_mainloop(self._mainloop, group_name)
        if self.cb is None:
            raise LNError("service %r: set_handler() before do_register()" % self.name, 35, 0)
        self._native.register(group_name)

    def do_register_with_mainloop(self, loop: MainloopInterface, group_name: str | None = None) -> None:
        """Registers the provider and lets `loop` handle its group's requests
        (as wait_and_handle_service_group_requests(group_name, 0) would)."""
        if not isinstance(loop, MainloopInterface):
            raise TypeError(
                "do_register_with_mainloop: loop must be a links_and_nodes.MainloopInterface, not %r" % (loop,)
            )
        if self.cb is None:
            raise LNError("service %r: set_handler() before do_register()" % self.name, 35, 0)
        self._mainloop = loop
        self._native.register(group_name)

        def on_work():
            self.clnt.wait_and_handle_service_group_requests(group_name, 0)
            return True

        self._loop_sources.append((loop, loop.fd_add(self.get_fd(), "in", on_work)))

    def do_register_gobject(self, group_name: str | None = None) -> None:
        """Deprecated in LN 2.9 (PyGTK): do_register_with_mainloop() on GLib's default context."""
        warnings.warn(
            "do_register_gobject() is deprecated: use do_register_with_mainloop()", DeprecationWarning, stacklevel=2
        )
        return self.do_register_with_mainloop(default_glib_mainloop(), group_name)

    do_register_gtk = do_register_gobject

    def _release(self):
        """Removes main-loop watches and releases the native service."""
        for loop, source in self._loop_sources:
            loop.source_remove(source)
        self._loop_sources = []
        self._remove_finish_watch()
        self._native.release()

    def get_fd(self) -> int:
        return self._native.get_fd()

    def utf8_decode_char_fields(self, do_decode: bool) -> None:
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
            ret = self.cb[0](request, self.req, self.resp, *self.cb[1])  # type: ignore[index]  # set_handler() set cb
        except Exception as error:
            log.error("error in service handler %s of %s:\n%s", self.cb[0], self.name, traceback.format_exc())  # type: ignore[index]  # set_handler() set cb
            if not native_request.responded:
                native_request.respond_error(-LNE_SVC_HANDLER_EXC, "%s: %s" % (type(error).__name__, error))
                return 0
            return -LNE_SVC_HANDLER_EXC
        if ret is None:
            return 0
        return int(ret)

    def respond(self, request: request_wrapper | _ln.Request) -> None:
        req = request.request if isinstance(request, request_wrapper) else request
        req.respond(self.resp._flat())


class ServiceFuture:
    """ln_core: an asynchronous service call (service_wrapper.call_future())."""

    def __init__(self, svc: service_wrapper) -> None:
        self._svc = svc

    def done(self) -> bool:
        try:
            return self._svc.finished()
        except LNError:
            return True

    def result(self, timeout: float | None = None) -> Any:
        """Waits (at most `timeout` seconds, None: no limit) and returns the
        service's `resp`; raises LNError if the call failed, TimeoutError if
        it is still running."""
        if not self._svc.finished(-1 if timeout is None else float(timeout)):
            raise TimeoutError("service %r: no response within %s s" % (self._svc.name, timeout))
        return self._svc.resp

    def exception(self, timeout: float | None = None) -> LNError | None:
        try:
            self.result(timeout)
        except LNError as error:
            return error
        return None

    def cancel(self) -> bool:
        self._svc.abort_async()
        return True
