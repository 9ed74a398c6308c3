"""Events (LN 2.9's client.connect_to_event): the connection's callback gets
each event as a message whose fields are attributes, in the thread that
handles the client's default service group
(``clnt.wait_and_handle_service_group_requests(None, timeout)`` or a thread
pool), one event at a time.

    def on_event(ev):
        print(ev.event, ev.name, ev.md, ev.client, ev.connection)

    conn = clnt.connect_to_event("ln.resource_event", "ln/resource_event", on_event,
                                 event_pattern="topic_*", name_pattern="*", md_pattern="*", client_pattern="*")
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from . import _ln
from ._errors import LNE_INVALID_SIGNATURE, LNError

if TYPE_CHECKING:
    from ._client import client


class event_connection_wrapper:
    """One connection to an event (what client.connect_to_event() returns).

    Attributes as in LN 2.9: ``clnt``, ``name``, ``interface``, ``callback``,
    ``connect_args``, ``connect_signature`` and ``call_signature``
    ("<definition>: <signature>"), ``connect_data`` (the flat connect section)
    and ``event_data`` (the message the callback gets; ``event_data.connection``
    is this object). ln_core adds ``id`` and ``disconnect()``.
    """

    def __init__(
        self,
        clnt: client,
        name: str,
        interface: str,
        callback: Callable[[Any], object],
        connect_args: Mapping[str, Any],
    ) -> None:
        if interface:
            definition, _ = clnt.get_service_signature(interface)
        else:
            interface, definition, _ = clnt.get_service_signature_for_service(name)
        model = clnt._model(interface, definition)
        if model["kind"] != "event":
            raise LNError(
                "'%s' is a %s definition, not an event definition" % (interface, model["kind"]),
                LNE_INVALID_SIGNATURE,
                0,
            )
        self.clnt, self.name, self.interface, self.callback = clnt, name, interface, callback
        self.connect_args = connect_args
        self.connection = None
        connect_side, call_side = model["signature"].split("|")
        self.connect_signature = "%s: %s" % (interface, connect_side)
        self.call_signature = "%s: %s" % (interface, call_side)
        connect = clnt._compiler.part_class(model, "fields", "::connect")(name=name + ".connect")
        for field, value in connect_args.items():
            if field not in connect._field_types:
                raise AttributeError(
                    "event definition '%s' has no connect field '%s'; its connect fields: %s"
                    % (interface, field, ", ".join(connect._fields) or "(none)")
                )
            setattr(connect, field, value)
        call_class = clnt._compiler.part_class(model, "response_fields", "::call")
        # A message whose fields are created at run time from the definition.
        self.event_data: Any = type(call_class.__name__, (call_class,), {"__slots__": ("connection",)})(
            name=name + ".call"
        )
        self.event_data.connection = self
        self.connect_data = bytes(connect._flat())
        self._native: _ln.EventConnection | None = _ln.EventConnection(
            clnt._native, name, self.connect_signature, self.connect_data, _deliverer(weakref.ref(self))
        )
        clnt._event_connections.add(self)

    @property
    def id(self) -> int:
        """ln_core: the connection's id (unique per client)."""
        return self._native.id if self._native is not None else 0

    def disconnect(self) -> None:
        """ln_core: no event reaches the callback afterwards."""
        native, self._native = self._native, None
        if native is not None:
            native.disconnect()
        self.clnt._event_connections.discard(self)

    def _deliver(self, data):
        self.event_data._decode(data)
        self.callback(self.event_data)

    def __str__(self) -> str:
        return "<ln.event_connection %s>" % self.name

    __repr__ = __str__


def _deliverer(wrapper_ref):
    # A weak reference: the native connection must not keep its wrapper alive.
    def deliver(data):
        wrapper = wrapper_ref()
        if wrapper is not None:
            wrapper._deliver(data)

    return deliver
