"""The "wrapped" service API: services as Python methods.

* Callers derive from services_wrapper and call wrap_service("method",
  "md/name"): self.method(**request_fields) calls "<prefix>.method" and
  returns the response (one value, a dict, or None); a non-empty
  error_message raises ServiceErrorResponse.
* Providers derive from service_provider and call
  wrap_service_provider("method", "md/name"): requests to "<prefix>.method"
  call self.method(**request_fields), whose return value (one value or a
  dict) fills the response.
"""

from __future__ import annotations

import logging
import pprint
import threading
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ._mainloop import MainloopInterface
from ._packets import Part, _is_ln_string

if TYPE_CHECKING:
    from typing import TypeAlias

    from ._client import client
    from ._services import request_wrapper

    #: A service_wrapper method name ("call", "call_gobject"), a main loop, or ("call_via_mainloop", loop).
    _CallMethod: TypeAlias = str | MainloopInterface | tuple[str, MainloopInterface] | list[Any]

log = logging.getLogger("links_and_nodes")


def _public_fields(part_class):
    """Field names without the `_len` companions of dynamic fields."""
    types = part_class._field_types
    return [
        name for name in part_class._fields if not (name.endswith("_len") and types.get(name[:-4], "").endswith("*"))
    ]


def _sub_class(part, name):
    value = getattr(part, name)
    if isinstance(value, Part):
        return type(value)
    descriptor = getattr(type(part), name)
    return getattr(descriptor, "cls", None)


def _set_field(part, name, value):
    """Sets a field, also from the plain values the wrapped API passes around:
    a str for an ln/string sub-type, a bare value for a one-field sub-type,
    dicts for sub-types, and lists of those."""
    cls = _sub_class(part, name)
    if cls is None or isinstance(value, Part) or (isinstance(value, list) and value and isinstance(value[0], Part)):
        setattr(part, name, value)
        return

    def convert(item):
        if isinstance(item, (dict, Part)):
            return item
        if _is_ln_string(cls(name="probe")):
            return {"string": item}
        if len(cls._fields) == 1:
            return {cls._fields[0]: item}
        return item

    if isinstance(value, (list, tuple)):
        setattr(part, name, [convert(item) for item in value])
    else:
        setattr(part, name, convert(value))


class ServiceErrorResponse(Exception):
    """A wrapped service call whose response signalled an error (a non-empty
    error indicator field such as error_message). `response` is the dict."""

    def __init__(self, error_indicator_fields: Iterable[str], response: Mapping[str, Any]) -> None:
        self.response = response
        rest = dict(response)
        text = ", ".join("%s: %s" % (field, rest.pop(field, None)) for field in error_indicator_fields)
        if rest:
            text += "\n%s" % pprint.pformat(rest)
        Exception.__init__(self, text)


class wrapped_service:
    """One wrapped service of a services_wrapper (callable)."""

    def __init__(
        self,
        clnt: client,
        service_name: str,
        interface: str,
        default_arguments: Mapping[str, Any] | None = None,
        preprocessors: Mapping[str, Callable[[Any], Any]] | None = None,
        postprocessors: Mapping[str, Callable[[Any], Any]] | None = None,
        postprocessor: Callable[[dict[str, Any]], Any] | None = None,
        call_method: _CallMethod = "call",
        throw_on_these_error_indicators: Sequence[str] | None = None,
    ) -> None:
        if isinstance(call_method, MainloopInterface):
            mainloop = call_method
        elif isinstance(call_method, (tuple, list)) and call_method and call_method[0] == "call_via_mainloop":
            mainloop = call_method[1]
        else:
            mainloop = None
        self.svc = clnt.get_service(service_name, interface, mainloop=mainloop)
        self.req_fields = _public_fields(self.svc._req_class)
        self.resp_fields = _public_fields(self.svc._resp_class)
        self.default_arguments = default_arguments or {}
        self.preprocessors = preprocessors or {}
        self.postprocessors = postprocessors or {}
        self.postprocessor = postprocessor
        self.call: Callable[..., Any] = (
            # a method name here: the other kinds of call_method give a mainloop
            self.svc.call_via_mainloop if mainloop is not None else getattr(self.svc, call_method)  # type: ignore[arg-type]
        )
        self.throw_on_these_error_indicators = (
            ["error_message"] if throw_on_these_error_indicators is None else throw_on_these_error_indicators
        )
        self.lock = threading.RLock()

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        """Calls the service with the request fields (positional in definition
        order, or by name; `_timeout` in seconds) and returns the response."""
        timeout = kwargs.pop("_timeout", 0)
        with self.lock:
            values = dict(zip(self.req_fields, args))
            if len(args) > len(self.req_fields):
                raise TypeError("%s takes at most %d arguments" % (self.svc.name, len(self.req_fields)))
            for name, value in kwargs.items():
                if name in values:
                    raise TypeError("argument %r given by position and by name" % name)
                if name not in self.req_fields:
                    raise AttributeError(
                        "service %r has no request field %r; fields: %s"
                        % (self.svc.name, name, ", ".join(self.req_fields))
                    )
                values[name] = value
            for name, value in self.default_arguments.items():
                values.setdefault(name, value)
            missing = [name for name in self.req_fields if name not in values]
            if missing:
                raise TypeError(
                    "service %r needs the request field(s) %s; pass them or give "
                    "default_arguments to wrap_service()" % (self.svc.name, ", ".join(missing))
                )
            for name, value in values.items():
                pre = self.preprocessors.get(name)
                if pre is not None:
                    value = pre(value)
                _set_field(self.svc.req, name, value)
            self.call(_timeout=timeout)
            ret = self.svc.resp.dict(detect_ln_string=True)
        for key in list(ret):
            if key.endswith("_len") and key[:-4] in ret:
                del ret[key]
        for name in list(ret):
            post = self.postprocessors.get(name)
            if post is not None:
                ret[name] = post(ret[name])
        if self.postprocessor is not None:
            ret = self.postprocessor(ret)
        if not isinstance(ret, dict):
            return ret
        for field in self.throw_on_these_error_indicators:
            if ret.get(field):
                raise ServiceErrorResponse(self.throw_on_these_error_indicators, ret)
        for field in self.throw_on_these_error_indicators:
            ret.pop(field, None)
        if len(ret) == 1:
            return next(iter(ret.values()))
        if not ret:
            return None
        return ret


class services_wrapper:
    """Base class for service callers: wrap_service() adds a method per service."""

    def __init__(self, clnt: client, service_prefix: str = "", mainloop: MainloopInterface | None = None) -> None:
        self.clnt = clnt
        self.service_prefix = service_prefix
        self.services: dict[str, wrapped_service] = {}
        self.default_call_method: _CallMethod = "call" if mainloop is None else mainloop

    def wrap_service(
        self,
        postfix: str,
        interface: str,
        default_arguments: Mapping[str, Any] | None = None,
        preprocessors: Mapping[str, Callable[[Any], Any]] | None = None,
        postprocessors: Mapping[str, Callable[[Any], Any]] | None = None,
        postprocessor: Callable[[dict[str, Any]], Any] | None = None,
        method_name: str | None = None,
        call_method: _CallMethod | None = None,
        throw_on_these_error_indicators: Sequence[str] | None = None,
    ) -> wrapped_service:
        """Adds self.<method_name> (default: postfix with '.' -> '_') calling
        the service "<prefix>.<postfix>" with interface `interface`."""
        service_name = self.service_prefix + "." + postfix if self.service_prefix else postfix
        svc = wrapped_service(
            self.clnt,
            service_name,
            interface,
            default_arguments,
            preprocessors,
            postprocessors,
            postprocessor,
            call_method or self.default_call_method,
            throw_on_these_error_indicators,
        )
        self.services[service_name] = svc
        setattr(self, method_name or postfix.replace(".", "_"), svc)
        return svc


class wrapped_service_provider:
    """One wrapped provider of a service_provider."""

    def __init__(
        self,
        provider: service_provider,
        service_name: str,
        interface: str,
        method: Callable[..., Any],
        preprocessors: Mapping[str, Callable[[wrapped_service_provider, Any, str], tuple[str, Any]]] | None = None,
        postprocessor: Callable[[wrapped_service_provider, Part, Any], object] | None = None,
        cleanup: Callable[[wrapped_service_provider, Part], object] | None = None,
        group_name: str | None = None,
        register_method: str | MainloopInterface = "do_register",
        pass_request: bool = False,
        utf8_decode_char_fields: bool = True,
    ) -> None:
        self.provider = provider
        self.clnt = provider.clnt
        self.svc = self.clnt.get_service_provider(service_name, interface)
        self.req_fields = _public_fields(self.svc._req_class)
        self.resp_fields = _public_fields(self.svc._resp_class)
        self.preprocessors = preprocessors or {}
        self.postprocessor = postprocessor
        self.cleanup = cleanup
        self.group_name = group_name
        self.method = method
        self.pass_request = pass_request
        self.has_error_message = "error_message" in self.resp_fields
        self.svc.set_handler(self.handler)
        if isinstance(register_method, MainloopInterface):
            self.svc.do_register_with_mainloop(register_method, group_name)
        else:
            getattr(self.svc, register_method)(group_name)

    def handler(self, request: request_wrapper, req: Part, resp: Part) -> int:
        kwargs: dict[str, Any] = {"request": request} if self.pass_request else {}
        for name in self.req_fields:
            value = getattr(req, name)
            pre = self.preprocessors.get(name)
            if pre is not None:
                name, value = pre(self, value, name)
            elif isinstance(value, Part):
                value = value.string if _is_ln_string(value) else value.dict()
            elif isinstance(value, list) and value and isinstance(value[0], Part):
                value = [item.string if _is_ln_string(item) else item for item in value]
            kwargs[name] = value
        try:
            ret = self.method(**kwargs)
        except Exception:
            if not self.has_error_message:
                raise
            log.error(
                "exception in handler %s of service provider %s:\n%s",
                self.method,
                self.svc.name,
                traceback.format_exc(),
            )
            ret = {"error_message": traceback.format_exc()}
        if self.postprocessor:
            self.postprocessor(self, resp, ret)
        else:
            self._fill_response(resp, ret)
        request.respond()
        if self.cleanup:
            self.cleanup(self, resp)
        return 0

    def _fill_response(self, resp, ret):
        fields = self.resp_fields
        if len(fields) == 1:
            if self.has_error_message:
                resp.error_message = ret.get("error_message", "") if isinstance(ret, dict) else str(ret)
            else:
                _set_field(resp, fields[0], ret)
            return
        if self.has_error_message and len(fields) == 2:
            other = fields[0] if fields[1] == "error_message" else fields[1]
            if isinstance(ret, dict):
                resp.error_message = ret.get("error_message", "")
                _set_field(resp, other, ret.get(other))
            else:
                resp.error_message = ""
                _set_field(resp, other, ret)
            return
        if not isinstance(ret, dict):
            raise TypeError(
                "service %s: the handler has to return a dict with the response fields %s, not %r"
                % (self.svc.name, ", ".join(fields), ret)
            )
        for name in fields:
            if name in ret:
                _set_field(resp, name, ret[name])
            else:
                delattr(resp, name)


class service_provider:
    """Base class for service providers: wrap_service_provider() serves a method."""

    #: LN 2.9 prints "ready" when handle_service_group_requests() starts.
    print_ready = True

    def __init__(
        self,
        clnt: client,
        service_prefix: str = "",
        default_register_method: str | MainloopInterface = "do_register",
        mainloop: MainloopInterface | None = None,
    ) -> None:
        self.clnt = clnt
        self.service_prefix = service_prefix
        self.services: dict[str, wrapped_service_provider] = {}
        self.default_register_method = default_register_method if mainloop is None else mainloop
        self.keep_running = True

    def wrap_service_provider(
        self,
        postfix: str,
        interface: str,
        preprocessors: Mapping[str, Callable[[wrapped_service_provider, Any, str], tuple[str, Any]]] | None = None,
        postprocessor: Callable[[wrapped_service_provider, Part, Any], object] | None = None,
        cleanup: Callable[[wrapped_service_provider, Part], object] | None = None,
        method: Callable[..., Any] | None = None,
        method_name: str | None = None,
        group_name: str | None = None,
        register_method: str | MainloopInterface | None = None,
        pass_request: bool = False,
        utf8_decode_char_fields: bool = True,
    ) -> wrapped_service_provider:
        """Serves "<prefix>.<postfix>" (interface `interface`) by self.<method_name>
        (default: postfix with '.' -> '_') or by `method`."""
        service_name = self.service_prefix + "." + postfix if self.service_prefix else postfix
        if method is None:
            method_name = method_name or postfix.replace(".", "_")
            if not hasattr(self, method_name):
                raise AttributeError(
                    "there is no method named %r in this class! define it or pass method= or method_name=" % method_name
                )
            method = getattr(self, method_name)
        svc = self.services[service_name] = wrapped_service_provider(
            self,
            service_name,
            interface,
            method,
            preprocessors=preprocessors,
            postprocessor=postprocessor,
            cleanup=cleanup,
            group_name=group_name,
            register_method=register_method or self.default_register_method,
            pass_request=pass_request,
            utf8_decode_char_fields=utf8_decode_char_fields,
        )
        return svc

    def handle_service_group_requests(self, group_name: str | None = None) -> None:
        """Serves requests of the group until self.keep_running is False
        (prints "ready" first, as LN 2.9 does)."""
        if self.print_ready:
            print("ready")
        self.keep_running = True
        while self.keep_running:
            self.clnt.wait_and_handle_service_group_requests(group_name, 0.5)
