"""Parameters (LN 2.9's Python API): client.get_parameters() reads and
overrides the parameters other clients provide; client.parameter_block()
provides parameters of this program.

Both speak LN's parameter services (ln/parameters/query_dict,
override_dict_single) with any provider or client, LN 2.9's or ln_core's, in
C++ or Python. The provider side is libln's (ln/parameters_c.h): the block
here keeps the values as numpy-packed bytes in the native bridge.

    params = clnt.get_parameters("controller")      # every "controller.*"
    params.gain                                      # value in effect (as last refreshed)
    params.gain = 2.5                                # override; None ends it
    params.get_dict()                                # all values, refreshed

    block = clnt.parameter_block("controller")
    block.add("gain", 1.5, description="P gain")
    block.add("limits", np.zeros((2, 3)))
    block.register()
    while running:
        out = block.update()                         # out.gain: value in effect
"""

from __future__ import annotations

import ast
import os
import pprint
import threading
import warnings
from collections import OrderedDict
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _ln
from ._errors import LNE_REQUEST_FAILED, LNE_UNKNOWN_PARAMETER, LNError

if TYPE_CHECKING:
    import builtins
    from collections.abc import Callable, Hashable, ItemsView, Iterator, KeysView, Mapping, Sequence
    from types import TracebackType
    from typing import Literal, Self, TypeAlias

    from _typeshed import SupportsItems
    from numpy.typing import DTypeLike

    from ._client import client, port_wrapper
    from ._services import service_wrapper

    #: one number or bool of a parameter value
    _Scalar: TypeAlias = "bool | int | float | np.generic"
    #: what a parameter takes: a scalar, a vector or a matrix (array or nested sequences)
    _ParameterValue: TypeAlias = "_Scalar | np.ndarray | Sequence[_Scalar] | Sequence[Sequence[_Scalar]]"
    #: what the client side knows of one parameter (input, output, override_enabled, ...)
    _ValueDict: TypeAlias = "dict[str, Any]"

__all__ = ["ParameterBlock", "ParameterOutputs", "ParameterSignal", "parameters_proxy"]

QUERY_INTERFACE = "ln/parameters/query_dict"
OVERRIDE_INTERFACE = "ln/parameters/override_dict_single"
TOPIC_INTERFACE = "ln/parameters/request_parameter_topic"

# ---------------------------------------------------------------- values

# Names a query_dict answer may use, as LN 2.9's Python client reads them
# (it evaluates the text with numpy's names and Python's builtins in scope:
# dtype=float is float64 there although providers write it for float32).
_LITERAL_NAMES = {
    "True": True,
    "False": False,
    "None": None,
    "nan": np.nan,
    "inf": np.inf,
    "double": np.float64,
    "float": float,
    "bool": bool,
    "int": int,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
}


def _literal(node: ast.AST) -> Any:
    """The value of one node of a parameter answer; only literals, lists,
    dict(...) and array(...) - nothing is evaluated."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float, str, bool, type(None))):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _literal(node.operand)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return -value if isinstance(node.op, ast.USub) else value
    elif isinstance(node, ast.Name) and node.id in _LITERAL_NAMES:
        return _LITERAL_NAMES[node.id]
    elif isinstance(node, (ast.List, ast.Tuple)):
        items = [_literal(e) for e in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    elif isinstance(node, ast.Dict):
        # a None key ({**x}) fails in ast.dump(): TypeError, a bad answer
        return OrderedDict((_literal(k), _literal(v)) for k, v in zip(node.keys, node.values))  # type: ignore[arg-type]
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        args = [_literal(a) for a in node.args]
        kwargs = {k.arg: _literal(k.value) for k in node.keywords}
        if node.func.id == "dict" and not args:
            return kwargs
        if node.func.id == "array" and len(args) == 1 and set(kwargs) <= {"dtype"}:
            return np.array(args[0], dtype=kwargs.get("dtype"))
    raise ValueError("unexpected %s in a parameter answer" % ast.dump(node)[:80])


def parse_parameter_text(text: str) -> Any:
    """A query_dict answer (or any parameter value text) as Python values."""
    try:
        return _literal(ast.parse(text.strip(), mode="eval").body)
    except (SyntaxError, ValueError, TypeError) as e:
        raise LNError("cannot read the parameter answer %r: %s" % (text[:200], e), LNE_REQUEST_FAILED, 0) from e


def _format_element(value: _Scalar) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "True" if value else "False"
    if isinstance(value, (np.integer, int)):
        return str(int(value))
    return repr(float(value))


def format_parameter_value(value: _ParameterValue) -> str:
    """A value as override text for a provider: a number, True/False, or
    array([...]) with nested lists for matrices (exact for every value)."""
    if isinstance(value, (list, tuple, np.ndarray)):
        array = np.asarray(value)
        if array.dtype.kind not in "biuf":
            raise TypeError("a parameter value is a number, a bool or an array of them, not %r" % (value,))

        def nested(a: np.ndarray) -> str:
            if a.ndim == 0:
                return _format_element(a.item())
            return "[" + ", ".join(nested(x) for x in a) + "]"

        return "array(%s)" % nested(array)
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (bool, int, float)):
        return _format_element(value)
    raise TypeError("a parameter value is a number, a bool or an array of them, not %r" % (value,))


# ---------------------------------------------------------------- client side


class _Hooks:
    """LN 2.9's hooked_object: add_hook(where, fn, from_who=None, arg=None);
    call_hook(where, *args) calls fn(self, *args) (fn(arg, self, *args) with
    arg); a hook that returns a false value is removed."""

    #: {where: {from_who: (fn, arg)}}, made by _init_hooks()
    hooks: dict[str, dict[Hashable, tuple[Callable[..., object], object]]]

    def _init_hooks(self) -> None:
        object.__setattr__(self, "hooks", {})

    def add_hook(
        self, where: str, to_what: Callable[..., object], from_who: Hashable | None = None, arg: object = None
    ) -> Self:
        hooks = self.hooks.setdefault(where, {})
        if from_who is None:
            n = len(hooks)
            while "unnamed %d" % n in hooks:
                n += 1
            from_who = "unnamed %d" % n
        hooks[from_who] = (to_what, arg)
        return self

    def remove_hooks_to(self, from_who: Hashable) -> None:
        for hooks in self.hooks.values():
            hooks.pop(from_who, None)

    def call_hook(self, where: str, *args: object) -> bool:
        hooks = self.hooks.get(where)
        if not hooks:
            return False
        for from_who, (fn, arg) in list(hooks.items()):
            try:
                keep = fn(self, *args) if arg is None else fn(arg, self, *args)
            except Exception as e:  # a hook's failure must not stop the others
                warnings.warn("hook %r of %r failed: %r" % (from_who, where, e), RuntimeWarning, stacklevel=2)
                keep = False
            if not keep:
                hooks.pop(from_who, None)
        return True


class parameters_proxy(_Hooks):
    """The parameters below a group name, from every client that provides
    some (LN 2.9's parameters_proxy). Attribute access reads the value in
    effect as of the last refresh; assignment overrides (None ends the
    override); subgroups ("a.b.c") are proxies too."""

    # set with object.__setattr__ (attribute access finds parameters)
    _parameters: OrderedDict[str, _ValueDict]
    _sub_blocks: OrderedDict[str, parameters_proxy]

    def __init__(
        self,
        clnt: client,
        parameters_name: str,
        allow_empty: bool = False,
        update_on_write: bool = True,
        do_parameter_scan: bool = True,
        record_call_stacks: bool = False,
        parent: parameters_proxy | None = None,
        debug: bool = False,
        use_parameter_prefix: bool = True,
    ) -> None:
        object.__setattr__(self, "_parameters", OrderedDict())
        object.__setattr__(self, "_sub_blocks", OrderedDict())
        self._init_hooks()
        self.clnt = clnt
        self.allow_empty = allow_empty
        self.record_call_stacks = record_call_stacks
        self._debug: bool = debug if parent is None else parent._debug
        # Services are shared by a proxy and its subgroups.
        self._services: dict[str, service_wrapper] = {} if parent is None else parent._services
        prefix = os.getenv("LN_PARAMETER_PREFIX", "") if use_parameter_prefix else ""
        name = prefix + parameters_name
        self.parameters_name = name[:-1] if name.endswith(".") else name
        self._update_on_write = update_on_write
        self._queued_overrides: OrderedDict[tuple[str, str], _ParameterValue | None] = OrderedDict()
        self.is_subscribed = False
        # (port, path in the packet, value dict)
        self._subscribed: list[tuple[port_wrapper, list[str], _ValueDict]] = []
        self._topic_ports: dict[str, port_wrapper] = {} if parent is None else parent._topic_ports
        self.lock = threading.RLock()
        self._in_on_update = False
        if do_parameter_scan:
            self._parameter_scan()

    # -- internals
    def _service(self, name: str, interface: str) -> service_wrapper:
        svc = self._services.get(name)
        if svc is None:
            svc = self._services[name] = self.clnt.get_service(name, interface)
        return svc

    def _query(self, service_name: str) -> dict[str, _ValueDict]:
        svc = self._service(service_name, QUERY_INTERFACE)
        svc.req.pattern = "%s*" % self.parameters_name
        svc()
        answer = parse_parameter_text(svc.resp.data)
        if not isinstance(answer, dict):
            raise LNError("%s answered no dict" % service_name, LNE_REQUEST_FAILED, 0)
        return answer

    def _parameter_scan(self) -> None:
        with self.lock:
            found = self.clnt.find_services_with_interface(QUERY_INTERFACE)
            services = [s for s in found.split("\n") if s.strip()]
            # Providers that left take their parameters with them.
            for short_name, value in list(self._parameters.items()):
                if value["service"] not in services:
                    del self._parameters[short_name]
            group = self.parameters_name + "."
            for service_name in services:
                for full_name, value in self._query(service_name).items():
                    if self.parameters_name == "":
                        short_name = full_name
                    elif full_name == self.parameters_name:
                        short_name = "value"
                    elif full_name.startswith(group):
                        short_name = full_name[len(group) :]
                    else:
                        continue
                    value["service"] = service_name
                    value["full_name"] = full_name
                    known = self._lookup(short_name)
                    if known is None:
                        self._add_parameter(short_name, value)
                    elif known["service"] != service_name:
                        warnings.warn(
                            "parameter %r is provided by %s and %s; using the first"
                            % (full_name, known["service"], service_name),
                            RuntimeWarning,
                            stacklevel=3,
                        )
            if not self.allow_empty and not self._parameters and not self._sub_blocks:
                raise LNError(
                    "no parameters matching %r found" % (self.parameters_name + "*"), LNE_UNKNOWN_PARAMETER, 0
                )

    def _lookup(self, short_name: str) -> _ValueDict | None:
        proxy: parameters_proxy | None
        proxy = self
        *groups, last = short_name.split(".")
        for group in groups:
            proxy = proxy._sub_blocks.get(group)
            if proxy is None:
                return None
        return proxy._parameters.get(last)

    def _add_parameter(self, short_name: str, value: _ValueDict) -> None:
        if "." not in short_name:
            self._parameters[short_name] = value
            return
        group, rest = short_name.split(".", 1)
        block = self._sub_blocks.get(group)
        if block is None:
            name = "%s.%s" % (self.parameters_name, group) if self.parameters_name else group
            block = self._sub_blocks[group] = parameters_proxy(
                self.clnt,
                name,
                update_on_write=self._update_on_write,
                do_parameter_scan=False,
                parent=self,
                use_parameter_prefix=False,
            )
        block._add_parameter(rest, value)

    def _all_parameters(self) -> Iterator[tuple[parameters_proxy, str, _ValueDict]]:
        """(proxy, short name, value) of this group and every subgroup."""
        for short_name, value in self._parameters.items():
            yield self, short_name, value
        for block in self._sub_blocks.values():
            yield from block._all_parameters()

    def _take_queued_overrides(self) -> list[tuple[tuple[str, str], _ParameterValue | None]]:
        queued = list(self._queued_overrides.items())
        self._queued_overrides.clear()
        for block in self._sub_blocks.values():
            queued.extend(block._take_queued_overrides())
        return queued

    def _call_on_update(self) -> bool:
        if self._in_on_update:
            return False
        try:
            self._in_on_update = True
            self.call_hook("on_update")
        finally:
            self._in_on_update = False
        return False

    # -- public API (LN 2.9)
    def refresh(self, short_name: str | None = None, wait_step: bool = False, rescan: bool = False) -> None:
        """Sends queued overrides, then reads the current values."""
        with self.lock:
            if rescan:
                self._parameter_scan()
            for (service_name, full_name), new_value in self._take_queued_overrides():
                svc = self._service(service_name.replace("query_dict", "override_dict_single"), OVERRIDE_INTERFACE)
                svc.req.parameter_name = full_name
                svc.req.override_data = "" if new_value is None else format_parameter_value(new_value)
                svc.req.wait_step = 1 if wait_step else 0
                svc()
                if svc.resp.error:
                    raise LNError(
                        "overriding parameter %r with %r failed: %s" % (full_name, new_value, svc.resp.error),
                        LNE_REQUEST_FAILED,
                        0,
                    )
            refreshed = {}
            for _, name, value in self._all_parameters():
                if short_name is not None and name != short_name:
                    continue
                service_name = value["service"]
                if service_name not in refreshed:
                    refreshed[service_name] = self._query(service_name)
                fresh = refreshed[service_name].get(value["full_name"])
                if fresh is not None:
                    value.update(fresh)
            self._call_on_update()

    def set_override(
        self, pname: str, override_value: _ParameterValue | None, update_on_write: bool = True, wait_step: bool = False
    ) -> None:
        """Overrides `pname` (a name of this group); None ends the override."""
        value = self._parameters[pname]
        self._queued_overrides[(value["service"], value["full_name"])] = override_value
        if self._update_on_write and update_on_write:
            self.refresh(wait_step=wait_step)

    def get_output(self, pname: str, value: _ValueDict | None = None, refresh: bool = True) -> Any:
        """The value in effect: the override while there is one."""
        if refresh:
            self.refresh()
        if value is None:
            value = self._parameters[pname]
        return value["output"] if value["override_enabled"] else value["input"]

    def get_input(self, pname: str, value: _ValueDict | None = None, refresh: bool = True) -> Any:
        """The provider's own value."""
        if refresh:
            self.refresh()
        if value is None:
            value = self._parameters[pname]
        return value["input"]

    def subscribe(self, rate: float = 10) -> set[port_wrapper]:
        """Subscribes to the topics the providers publish these parameters on
        (ln/parameters/request_parameter_topic; they publish for 10 s, then
        while subscribed); read() then takes the values from there. Returns
        the ports."""
        with self.lock:
            wanted: OrderedDict[str, list[str]] = OrderedDict()
            for _, _, value in self._all_parameters():
                wanted.setdefault(value["service"], []).append(value["full_name"])
            topics = {}
            for service_name, names in wanted.items():
                svc = self._service(service_name.replace("query_dict", "request_topic"), TOPIC_INTERFACE)
                svc.req.parameters = ", ".join(names)
                svc()
                if svc.resp.error:
                    raise LNError("topics of %s: %s" % (service_name, svc.resp.error), LNE_REQUEST_FAILED, 0)
                topics.update(parse_parameter_text(svc.resp.parameter_topics))
            self._subscribed = []
            for _, _, value in self._all_parameters():
                topic, md = topics[value["full_name"]]
                port = self._topic_ports.get(topic)
                if port is None:
                    port = self._topic_ports[topic] = self.clnt.subscribe(topic, md, rate=rate)
                self._subscribed.append((port, value["full_name"].split("."), value))
            self.is_subscribed = True
            return set(port for port, _, _ in self._subscribed)

    def read(self, blocking: bool | float | str = True, mainloop: object = None) -> None:
        """Waits for the next packet of every subscribed topic (blocking:
        True, False, a timeout, or a parameter name: only its topic), then
        updates the values from them."""
        with self.lock:
            if not self.is_subscribed:
                raise LNError("read() needs subscribe() first", LNE_REQUEST_FAILED, 0)
            if blocking is True or blocking is False or isinstance(blocking, (int, float)):
                for port in set(port for port, _, _ in self._subscribed):
                    port.read(blocking)
            else:
                full_name = blocking if "." in blocking else "%s.%s" % (self.parameters_name, blocking)
                for port, path, _ in self._subscribed:
                    if ".".join(path) in (blocking, full_name):
                        port.read(True)
                        break
            for port, path, value in self._subscribed:
                part = port.packet
                for item in path:
                    part = getattr(part, item)
                fresh = part.dict()
                for key in ("input", "output"):
                    old = value[key]
                    new = fresh[key]
                    if isinstance(old, np.ndarray):
                        new = np.asarray(new, dtype=old.dtype).reshape(old.shape)
                    elif isinstance(old, bool):
                        new = bool(new)
                    elif isinstance(old, float):
                        new = float(new)
                    value[key] = new
                value["override_enabled"] = bool(fresh["override_enabled"])
            self._call_on_update()

    def get_dict(self, refresh: bool = True, full: bool = False) -> dict[str, Any]:
        """{name: value in effect} (full: {name: {input, output,
        override_enabled, description}}), subgroups as nested dicts."""
        if refresh:
            self.refresh()
        d = {}
        for pname, value in self._parameters.items():
            d[pname] = self.get_signal_full_dict(pname, value) if full else self.get_output(pname, value, refresh=False)
        for bname, block in self._sub_blocks.items():
            d[bname] = block.get_dict(refresh=False, full=full)
        return d

    def get_signal_full_dict(self, signal_name: str, value: _ValueDict | None = None) -> dict[str, Any]:
        if value is None:
            value = self._parameters[signal_name]
        d = {key: value[key] for key in ("input", "output", "override_enabled")}
        d["description"] = value.get("description", "")
        return d

    def __getitem__(self, name: str) -> _ValueDict:
        return self._parameters[name]

    def __contains__(self, name: object) -> bool:
        return name in self._parameters

    def __getattr__(self, name: str) -> Any:
        parameters = self.__dict__.get("_parameters", {})
        if name in parameters:
            return self.get_output(name, parameters[name], refresh=False)
        block = self.__dict__.get("_sub_blocks", {}).get(name)
        if block is not None:
            return block
        raise AttributeError(name)

    def __setattr__(self, name: str, new_value: Any) -> None:
        if name in self.__dict__.get("_parameters", {}):
            self.set_override(name, new_value)
        else:
            object.__setattr__(self, name, new_value)

    def __dir__(self) -> list[str]:
        return list(super().__dir__()) + list(self._parameters) + list(self._sub_blocks)

    def __str__(self) -> str:
        return "<ln_parameters_proxy %r\n%s>" % (self.parameters_name, pprint.pformat(self.get_dict()))

    def __repr__(self) -> str:
        return "<ln_parameters_proxy@%#x %r\n%s>" % (id(self), self.parameters_name, pprint.pformat(self.get_dict()))


# ---------------------------------------------------------------- provider side

_DTYPE_ALIASES = {
    "double": np.float64,
    "float64": np.float64,
    "float64_t": np.float64,
    "single": np.float32,
    "float": np.float32,
    "float32": np.float32,
    "float32_t": np.float32,
    "bool": np.bool_,
    "boolean": np.bool_,
    "int8": np.int8,
    "int8_t": np.int8,
    "uint8": np.uint8,
    "uint8_t": np.uint8,
    "int16": np.int16,
    "int16_t": np.int16,
    "short": np.int16,
    "uint16": np.uint16,
    "uint16_t": np.uint16,
    "int32": np.int32,
    "int32_t": np.int32,
    "int": np.int32,
    "uint32": np.uint32,
    "uint32_t": np.uint32,
    "int64": np.int64,
    "int64_t": np.int64,
    "uint64": np.uint64,
    "uint64_t": np.uint64,
}

_TYPE_IDS = {
    np.dtype(np.float64): _ln.LN_PARAM_DOUBLE,
    np.dtype(np.float32): _ln.LN_PARAM_SINGLE,
    np.dtype(np.int8): _ln.LN_PARAM_INT8,
    np.dtype(np.uint8): _ln.LN_PARAM_UINT8,
    np.dtype(np.int16): _ln.LN_PARAM_INT16,
    np.dtype(np.uint16): _ln.LN_PARAM_UINT16,
    np.dtype(np.int32): _ln.LN_PARAM_INT32,
    np.dtype(np.uint32): _ln.LN_PARAM_UINT32,
    np.dtype(np.bool_): _ln.LN_PARAM_BOOLEAN,
    np.dtype(np.int64): _ln.LN_PARAM_INT64,
    np.dtype(np.uint64): _ln.LN_PARAM_UINT64,
}


def _normalize_dtype(dtype: DTypeLike) -> np.dtype[Any]:
    if isinstance(dtype, str):
        dtype = _DTYPE_ALIASES.get(dtype, dtype)
    try:
        dtype = np.dtype(dtype)
    except TypeError:
        raise TypeError("unsupported parameter dtype %r" % (dtype,)) from None
    if dtype not in _TYPE_IDS:
        raise TypeError("unsupported parameter dtype %r (bool, int8..uint64, float32, float64)" % (dtype,))
    return dtype


def _infer_dtype(value: _ParameterValue) -> np.dtype[Any]:
    if isinstance(value, (bool, np.bool_)):
        return np.dtype(np.bool_)
    if isinstance(value, (float, np.floating)):
        return np.dtype(np.float64)
    if isinstance(value, (int, np.integer)):
        return np.dtype(np.int64)
    dtype = np.asarray(value).dtype
    if dtype.kind in "iu":
        size = 1 if dtype.itemsize <= 1 else 2 if dtype.itemsize <= 2 else 4 if dtype.itemsize <= 4 else 8
        return np.dtype("%s%d" % ("u" if dtype.kind == "u" else "i", size))
    if dtype.kind == "f":
        return np.dtype(np.float32 if dtype.itemsize <= 4 else np.float64)
    if dtype.kind == "b":
        return np.dtype(np.bool_)
    raise TypeError("cannot infer a parameter dtype from %r (%s)" % (value, dtype))


def _normalize_shape(value: _ParameterValue, shape: int | np.integer | Sequence[int] | None) -> tuple[int, ...]:
    if shape is None:
        shape = np.asarray(value).shape
    elif isinstance(shape, (int, np.integer)):
        shape = (int(shape),)
    shape = tuple(int(d) for d in shape)
    if len(shape) > 2:
        raise ValueError("parameters are scalars, vectors or matrices, not of shape %r" % (shape,))
    if any(d <= 0 for d in shape):
        raise ValueError("parameter dimensions must be positive, not %r" % (shape,))
    return shape


def _checked_array(value: _ParameterValue, dtype: np.dtype[Any], shape: tuple[int, ...], name: str) -> np.ndarray:
    """`value` as a C-contiguous array of `dtype` and `shape`; integers must
    be integral and fit."""
    raw = np.asarray(value)
    if raw.dtype.kind not in "biuf":
        raise TypeError("parameter %r takes numbers, not %r" % (name, value))
    if dtype.kind in "iu" and raw.size:
        if raw.dtype.kind == "f" and (not np.all(np.isfinite(raw)) or not np.all(raw == np.round(raw))):
            raise ValueError("parameter %r (%s) takes integral values, not %r" % (name, dtype, value))
        info = np.iinfo(dtype)
        as_object = raw.astype(object) if raw.dtype.kind in "iu" else raw
        if np.any(as_object < info.min) or np.any(as_object > info.max):
            raise ValueError("parameter %r: %r does not fit %s (%d..%d)" % (name, value, dtype, info.min, info.max))
    array = np.asarray(value, dtype=dtype)
    if shape == ():
        if array.size != 1:
            raise ValueError("parameter %r is a scalar, not of shape %r" % (name, array.shape))
        array = array.reshape(())
    elif array.shape != shape:
        raise ValueError("parameter %r has shape %r, not %r" % (name, shape, array.shape))
    return np.ascontiguousarray(array)


def _unpack(data: bytes, dtype: np.dtype[Any], shape: tuple[int, ...]) -> Any:
    array = np.frombuffer(data, dtype=dtype)
    if shape == ():
        return array[0].item()
    return array.reshape(shape).copy()


class _Named:
    """[name], `in`, keys(), items() and iteration over the dict _named()."""

    if TYPE_CHECKING:

        def _named(self) -> Mapping[str, Any]: ...

    def __getitem__(self, name: str) -> Any:
        return self._named()[name]

    def __contains__(self, name: object) -> bool:
        return name in self._named()

    def keys(self) -> KeysView[str]:
        return self._named().keys()

    def items(self) -> ItemsView[str, Any]:
        return self._named().items()

    def __iter__(self) -> Iterator[str]:
        return iter(self._named())


class ParameterOutputs(_Named):
    """The values in effect after ParameterBlock.update(): by attribute,
    item or as a dict."""

    def __init__(self, values: Mapping[str, Any]) -> None:
        self._values = values

    def _named(self) -> Mapping[str, Any]:
        return self._values

    def __getattr__(self, name: str) -> Any:
        try:
            return self.__dict__["_values"][name]
        except KeyError:
            raise AttributeError(name) from None

    def get(self, name: str, default: Any = None) -> Any:
        return self._values.get(name, default)

    def dict(self) -> builtins.dict[str, Any]:
        return dict(self._values)

    def __repr__(self) -> str:
        return "ParameterOutputs(%r)" % (self._values,)


class ParameterSignal:
    """One parameter of a ParameterBlock: .input is the program's value
    (settable), .output the value in effect after the last update()."""

    def __init__(
        self,
        block: ParameterBlock,
        index: int,
        name: str,
        description: str,
        dtype: np.dtype[Any],
        shape: tuple[int, ...],
        has_output: bool,
        value: Any,
    ) -> None:
        self._block = block
        self._index = index
        self.name = name
        self.description = description
        self.dtype = dtype
        self.shape = shape
        self.has_output = has_output
        self._input = value

    @property
    def input(self) -> Any:
        with self._block.lock:
            return self._input

    @input.setter
    def input(self, value: _ParameterValue) -> None:
        self._block._set_input(self, value)

    @property
    def output(self) -> Any:
        return self._block._output(self)

    def __repr__(self) -> str:
        return "<ln.ParameterSignal %r dtype=%s shape=%r>" % (self.name, self.dtype, self.shape)


class ParameterBlock(_Named):
    """Parameters this program provides under `parameter_group_name`
    (client.parameter_block()). add() every parameter, register(), then call
    update() once per loop iteration: it publishes the inputs and returns
    the values in effect (overrides included)."""

    if TYPE_CHECKING:
        # add() makes each parameter with an identifier name an attribute
        def __getattr__(self, name: str) -> ParameterSignal: ...

    def __init__(
        self, clnt: client, parameter_group_name: str, always_publish: bool = False, topic_name: str = ""
    ) -> None:
        self.clnt = clnt
        self.parameter_group_name = parameter_group_name
        self.always_publish = always_publish
        self.topic_name = topic_name
        self.lock = threading.RLock()
        self._bridge = _ln.ParameterBlockBridge(clnt._native, parameter_group_name, bool(always_publish), topic_name)
        self._signals: OrderedDict[str, ParameterSignal] = OrderedDict()
        self._registered = False
        self._in_update = False

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc_value: BaseException | None, tb: TracebackType | None
    ) -> Literal[False]:
        if exc_type is None and not self._registered:
            self.register()
        return False

    def add(
        self,
        name: str,
        value: _ParameterValue,
        description: str | None = "",
        dtype: DTypeLike | None = None,
        shape: int | np.integer | Sequence[int] | None = None,
        output: bool = True,
        before_update: Callable[[Any], object] | None = None,
        after_update: Callable[[Any], object] | None = None,
    ) -> ParameterSignal:
        """Adds a parameter with initial value `value` (dtype and shape from
        it unless given). before_update(new_value) -> bool may refuse an
        override (runs in a library thread); after_update(value) runs in
        update() when an override takes effect."""
        with self.lock:
            if self._registered:
                raise RuntimeError("parameters cannot be added after register()")
            if not isinstance(name, str) or not name:
                raise ValueError("a parameter name is a non-empty string, not %r" % (name,))
            if name in self._signals:
                raise ValueError("parameter %r is added already" % name)
            for callback, what in ((before_update, "before_update"), (after_update, "after_update")):
                if callback is not None and not callable(callback):
                    raise TypeError("%s must be callable or None" % what)
            dtype = _infer_dtype(value) if dtype is None else _normalize_dtype(dtype)
            shape = _normalize_shape(value, shape)
            array = _checked_array(value, dtype, shape, name)
            initial = array.item() if shape == () else array.copy()
            signal = ParameterSignal(
                self,
                len(self._signals),
                name,
                "" if description is None else str(description),
                dtype,
                shape,
                bool(output),
                initial,
            )
            self._bridge.add_signal(
                name,
                signal.description,
                _TYPE_IDS[dtype],
                list(shape or (1,)),
                self._wrap(before_update, dtype, shape, name, refuse_on_error=True),
                self._wrap(after_update, dtype, shape, name, refuse_on_error=False),
                bool(output),
            )
            self._bridge.set_input(signal._index, array.tobytes())
            self._signals[name] = signal
            if name.isidentifier() and not name.startswith("_") and not hasattr(self, name):
                object.__setattr__(self, name, signal)
            return signal

    @staticmethod
    def _wrap(
        callback: Callable[[Any], object] | None,
        dtype: np.dtype[Any],
        shape: tuple[int, ...],
        name: str,
        refuse_on_error: bool,
    ) -> Callable[[bytes], bool | None] | None:
        if callback is None:
            return None

        def from_bytes(data: bytes) -> bool | None:
            try:
                result = callback(_unpack(data, dtype, shape))
            except Exception as e:  # the library gets a plain answer, the program a warning
                warnings.warn("parameter %r: %s failed: %r" % (name, callback, e), RuntimeWarning)
                return False if refuse_on_error else None
            return bool(result) if refuse_on_error else None

        return from_bytes

    def register(self) -> Self:
        """Makes the parameters visible to other clients (once)."""
        with self.lock:
            if self._registered:
                raise RuntimeError("the parameter block is registered already")
            self._sync_inputs()
            self._bridge.register()
            self._registered = True
            return self

    def _sync_inputs(self) -> None:
        # Arrays may have been changed in place (block.vec.input[0] = 5).
        for signal in self._signals.values():
            array = _checked_array(signal._input, signal.dtype, signal.shape, signal.name)
            self._bridge.set_input(signal._index, array.tobytes())

    def update(
        self, mapping: SupportsItems[str, _ParameterValue] | None = None, **inputs: _ParameterValue
    ) -> ParameterOutputs:
        """Sets the inputs given (a mapping and/or keywords), publishes all
        inputs, applies overrides; returns ParameterOutputs."""
        with self.lock:
            if not self._registered:
                raise RuntimeError("register() the parameter block before update()")
            if self._in_update:
                raise RuntimeError("update() called from within update()")
            if mapping is not None:
                if not hasattr(mapping, "items"):
                    raise TypeError("update() takes a mapping (with items()) and keywords")
                inputs = dict(mapping.items(), **inputs)
            for name, value in inputs.items():
                if name not in self._signals:
                    raise KeyError("unknown parameter %r" % name)
                self._set_input(self._signals[name], value)
            self._sync_inputs()
            self._in_update = True
            try:
                self._bridge.update()
            finally:
                self._in_update = False
            return ParameterOutputs(OrderedDict((s.name, self._output(s)) for s in self._signals.values()))

    def _set_input(self, signal: ParameterSignal, value: _ParameterValue) -> None:
        with self.lock:
            array = _checked_array(value, signal.dtype, signal.shape, signal.name)
            self._bridge.set_input(signal._index, array.tobytes())
            if signal.shape == ():
                signal._input = array.item()
            else:
                signal._input[...] = array

    def _output(self, signal: ParameterSignal) -> Any:
        with self.lock:
            return _unpack(self._bridge.output(signal._index), signal.dtype, signal.shape)

    def _named(self) -> Mapping[str, ParameterSignal]:
        return self._signals

    def __repr__(self) -> str:
        return "<ln.ParameterBlock %r signals=%r registered=%r>" % (
            self.parameter_group_name,
            list(self._signals),
            self._registered,
        )
