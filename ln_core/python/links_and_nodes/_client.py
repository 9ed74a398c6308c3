"""The client, topic ports and the multi-waiter (LN 2.9's Python API)."""

from __future__ import annotations

import atexit
import weakref
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from . import _introspection, _ln
from ._errors import LNE_INVALID_PARAMETER, LNError
from ._packets import Compiler, ln29_definition

if TYPE_CHECKING:
    from ._events import event_connection_wrapper
    from ._introspection import client_info, manager_status, process_info, process_output, service_info, topic_info
    from ._loggers import logger
    from ._mainloop import MainloopInterface
    from ._parameters import ParameterBlock, parameters_proxy
    from ._services import service_wrapper

_live_clients: weakref.WeakSet[client] = weakref.WeakSet()


@atexit.register
def _close_all() -> None:
    # Library threads must not call into Python while it shuts down.
    for clnt in list(_live_clients):
        try:
            clnt.close()
        except Exception:
            pass


def _checked_buffers(buffers: int) -> int:
    count = int(buffers)
    if count < 1:
        raise ValueError("buffers must be at least 1, not %r" % (buffers,))
    return count


class client:
    """A connection to the ln_manager.

    client(client_name, ln_manager_or_args=None): ``ln_manager_or_args`` is
    "HOST:PORT", a list of command-line arguments (``sys.argv``, parsed for
    --ln-manager, --ln-program-name, ...), or None for $LN_MANAGER.
    """

    def __init__(self, client_name: str, ln_manager_or_args: str | bytes | Sequence[str] | None = None) -> None:
        if isinstance(ln_manager_or_args, (list, tuple)):
            native = _ln.Client(client_name, None, [str(a) for a in ln_manager_or_args])
        elif ln_manager_or_args is None or isinstance(ln_manager_or_args, str):
            native = _ln.Client(client_name, ln_manager_or_args or None, None)
        elif isinstance(ln_manager_or_args, bytes):
            native = _ln.Client(client_name, ln_manager_or_args.decode(), None)
        else:
            raise TypeError(
                "ln_manager_or_args must be 'HOST:PORT', a list of arguments or None, not %r" % (ln_manager_or_args,)
            )
        self._native = native
        self.name = native.name
        self._compiler = Compiler()
        self._models: dict[str, dict] = {}
        self._services: set[service_wrapper] = set()
        self._event_connections: set[event_connection_wrapper] = set()
        self._availability: dict[str, Any] = {}
        _live_clients.add(self)

    # -- life cycle -------------------------------------------------------
    def close(self) -> None:
        """Unregisters from the manager; ports and services become unusable."""
        for svc in list(self._services):
            svc._release()
        self._services.clear()
        for connection in list(self._event_connections):
            connection.disconnect()
        self._native.close()

    def __enter__(self) -> client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return "<links_and_nodes.client %r>" % self.name

    # -- message definitions ----------------------------------------------
    def _model(self, md_name: str, text: str | None = None) -> dict:
        model = self._models.get(md_name)
        if model is None or (text is not None and model.get("_text") != text):
            model = self._native.model(md_name, text)
            model["_text"] = text
            self._models[md_name] = model
        return model

    def get_message_definition(self, message_definition_name: str) -> tuple[str, int, str, str]:
        """(definition, message size, hash, flat definition); the definition
        is the dict text LN 2.9 returns (fields as [type, name, count])."""
        text, size, md_hash, flat = self._native.get_message_definition(message_definition_name)
        model = self._model(message_definition_name)
        return repr(ln29_definition(model)), size, md_hash, flat

    def get_message_definition_for_topic(self, topic_name: str) -> tuple[str, str, int, str]:
        """(message definition name, definition, message size, hash)."""
        md_name, text, size, md_hash = self._native.get_message_definition_for_topic(topic_name)
        return md_name, repr(ln29_definition(self._model(md_name))), size, md_hash

    def get_message_definition_text(self, message_definition_name: str) -> str:
        """ln_core: the definition's own text as in its file."""
        return self._native.get_message_definition(message_definition_name)[0]

    def describe_message_definition(self, message_definition_name: str) -> str:
        return self._native.describe_message_definition(message_definition_name)

    def put_message_definition(self, message_definition_name: str, message_definition: str) -> str:
        return self._native.put_message_definition(message_definition_name, message_definition)

    def locate_member_in_message_definition(self, message_definition_name: str, member: str) -> tuple[int, int]:
        """(byte offset, byte length) of a member path such as "pose.position[2]"."""
        return self._native.locate_member(message_definition_name, member)

    def get_service_signature(self, service_interface: str) -> tuple[str, str]:
        """(definition text, signature) of a service interface."""
        return self._native.get_service_signature(service_interface)

    def get_service_signature_for_service(self, service_name: str) -> tuple[str, str, str]:
        """(interface, definition text, signature) of a registered service."""
        return self._native.get_service_signature_for_service(service_name)

    def find_services_with_interface(self, interface_name: str) -> str:
        """The names of the services with this interface, one per line (a
        str, as LN 2.9 returns them; "" for none)."""
        return "\n".join(self._native.find_services_with_interface(interface_name))

    # -- topics -----------------------------------------------------------
    def _topic_model(self, md_name: str) -> tuple[dict, type]:
        model = self._model(md_name)
        if model["kind"] != "plain":
            raise LNError(
                "'%s' is a %s definition, not a topic message" % (md_name, model["kind"]), LNE_INVALID_PARAMETER, 0
            )
        cls = self._compiler.part_class(model)
        if not cls._fixed:
            raise LNError(
                "'%s' has dynamic fields, which topics cannot carry (LN sends fixed-size "
                "packets): use a fixed array and a count field" % md_name,
                LNE_INVALID_PARAMETER,
                0,
            )
        return model, cls

    def publish(self, topic_name: str, message_definition_name: str = "", buffers: int = 1) -> port_wrapper:
        """Becomes the publisher of a topic; returns its port."""
        buffers = _checked_buffers(buffers)
        md_name = message_definition_name.split("|")[0]
        model, cls = self._topic_model(md_name)
        native = _ln.OutPort(self._native, topic_name, message_definition_name, buffers)
        return port_wrapper(md_name, cls, native, self, topic_name)

    def subscribe(
        self,
        topic_name: str,
        message_definition_name: str | None = None,
        rate: float = -1,
        buffers: int = 1,
        need_reliable_transport: bool = False,
    ) -> port_wrapper:
        """Subscribes to a topic; `message_definition_name` None asks the manager."""
        if message_definition_name is None or message_definition_name == "":
            message_definition_name = str(self._native.get_message_definition_for_topic(topic_name)[0])
        elif not isinstance(message_definition_name, str):
            raise TypeError(
                "subscribe: message_definition_name must be None or a str, not %r" % (message_definition_name,)
            )
        buffers = _checked_buffers(buffers)
        md_name = message_definition_name.split("|")[0]
        model, cls = self._topic_model(md_name)
        native = _ln.InPort(
            self._native, topic_name, message_definition_name, float(rate), buffers, bool(need_reliable_transport)
        )
        return port_wrapper(md_name, cls, native, self, topic_name, need_reliable_transport)

    def unpublish(self, port: port_wrapper) -> None:
        port.port.unpublish()

    def unsubscribe(self, port: port_wrapper) -> None:
        port.port.unsubscribe()

    def get_multi_waiter(self) -> multi_waiter:
        return multi_waiter(self)

    # -- topic loggers ----------------------------------------------------
    def get_logger(self, logger_name: str) -> logger:
        """The topic logger of that name (made on first use); the manager records."""
        from ._loggers import logger

        return logger(_ln.get_logger(self._native, logger_name))

    # -- services ---------------------------------------------------------
    def get_service(
        self, service_name: str, interface_name: str = "", mainloop: MainloopInterface | None = None
    ) -> service_wrapper:
        """A service to call. Without interface_name the running provider's is
        used. With a `mainloop` (a MainloopInterface), call() runs that loop
        while it waits."""
        from ._services import service_wrapper

        if interface_name:
            definition, signature = self._native.get_service_signature(interface_name)
        else:
            interface_name, definition, signature = self._native.get_service_signature_for_service(service_name)
        return service_wrapper(
            self, service_name, interface_name, definition, signature, is_provider=False, mainloop=mainloop
        )

    def get_service_provider(
        self, service_name: str, interface_name: str, mainloop: MainloopInterface | None = None
    ) -> service_wrapper:
        """A service to provide: set_handler(), then do_register(). With a
        `mainloop`, do_register() makes that loop handle the requests."""
        from ._services import service_wrapper

        definition, signature = self._native.get_service_signature(interface_name)
        svc = service_wrapper(
            self, service_name, interface_name, definition, signature, is_provider=True, mainloop=mainloop
        )
        self._services.add(svc)
        return svc

    def release_service(self, svc: service_wrapper) -> None:
        self._services.discard(svc)
        svc._release()

    def wait_and_handle_service_group_requests(self, group_name: str | None = None, timeout: float = -1) -> None:
        """Runs handlers of the group's providers in this thread; waits at most
        `timeout` seconds (-1: until something was handled)."""
        self._native.wait_and_handle_service_group_requests(group_name, float(timeout))

    def handle_service_group_in_thread_pool(self, group_name: str | None, pool_name: str) -> None:
        self._native.handle_service_group_in_thread_pool(group_name, pool_name)

    def remove_service_group_from_thread_pool(self, group_name: str | None) -> None:
        self._native.remove_service_group_from_thread_pool(group_name)

    def unblock_service_group(self, group_name: str | None) -> None:
        self._native.unblock_service_group(group_name)

    def set_max_threads(self, pool_name: str, n_threads: int) -> None:
        self._native.set_max_threads(pool_name, int(n_threads))

    def thread_pool_setschedparam(self, pool_name: str, policy: int, priority: int, affinity_mask: int) -> None:
        self._native.thread_pool_setschedparam(pool_name, int(policy), int(priority), int(affinity_mask))

    def needs_provider(self, service_or_topic_name: str, timeout: float = -1) -> None:
        self._native.needs_provider(service_or_topic_name, float(timeout))

    def wait_for_service(self, service_name: str, timeout: float = -1) -> bool:
        """ln_core: True once a provider of the service is registered (never
        starts one), False if none came within `timeout` seconds."""
        return self._native.wait_for_service(service_name, float(timeout))

    def set_service_availability_handler(
        self, service_name: str, handler: Callable[[str, bool], object] | None
    ) -> None:
        """ln_core: handler(service_name, available) now and at every change
        (called from a library thread); None removes it."""
        self._native.set_availability_handler(True, service_name, handler)

    def set_publisher_availability_handler(
        self, topic_name: str, handler: Callable[[str, bool], object] | None
    ) -> None:
        """ln_core: handler(topic_name, has_publisher) now and at every change."""
        self._native.set_availability_handler(False, topic_name, handler)

    # -- introspection (ln_core) -------------------------------------------
    def list_topics(self) -> list[topic_info]:
        """ln_core: the topics the manager knows, as a list of ln.topic_info."""
        return _introspection.list_topics(self._native)

    def list_clients(self) -> list[client_info]:
        """ln_core: the registered clients, as a list of ln.client_info."""
        return _introspection.list_clients(self._native)

    def list_services(self) -> list[service_info]:
        """ln_core: the registered services, as a list of ln.service_info."""
        return _introspection.list_services(self._native)

    def get_manager_status(self) -> manager_status:
        """ln_core: the manager's version, pid, address, uptime, counts and
        definition search path, as ln.manager_status."""
        return _introspection.get_manager_status(self._native)

    # -- processes of the manager's config (ln_core) ----------------------
    def list_processes(self) -> list[process_info]:
        """ln_core: the manager's processes, states and groups, as a list of
        ln.process_info (processes first, each kind in config order)."""
        return _introspection.list_processes(self._native)

    def control_process(self, name: str, action: str, alt_command: str | None = None) -> None:
        """ln_core: asks the manager to "start", "stop" or "restart" a
        process or group, or to bring a state "up", "down" or "check" it.
        Returns once the manager accepted; list_processes() shows progress."""
        _introspection.control_process(self._native, name, action, alt_command)

    def get_process_output(self, name: str, after: int = 0) -> process_output:
        """ln_core: the lines a process or state printed after line number
        `after`, as ln.process_output."""
        return _introspection.get_process_output(self._native, name, after)

    # -- misc -------------------------------------------------------------
    def ping(self, timeout: float = -1) -> float:
        return self._native.ping(float(timeout))

    def get_remaining_args(self) -> list[str]:
        return self._native.get_remaining_args()

    def set_thread_safe(self, thread_safe: bool) -> None:
        self._native.set_thread_safe(bool(thread_safe))

    def set_float_parameter(self, name: str, value: float) -> None:
        self._native.set_float_parameter(name, float(value))

    def register_as_service_logger(self, logger_service_name: str, service_name_patterns_to_log: str) -> None:
        self._native.register_as_service_logger(logger_service_name, service_name_patterns_to_log)

    def get_parameters(self, parameter_group_prefix: str = "", allow_empty: bool = False) -> parameters_proxy:
        """The parameters other clients provide below `parameter_group_prefix`
        (LN_PARAMETER_PREFIX in front), as a parameters_proxy; fails if there
        are none, unless allow_empty."""
        from ._parameters import parameters_proxy

        return parameters_proxy(self, parameter_group_prefix, allow_empty)

    def parameter_block(
        self, parameter_group_name: str, always_publish: bool = False, topic_name: str = ""
    ) -> ParameterBlock:
        """Parameters this program provides, named
        "<LN_PARAMETER_PREFIX><parameter_group_name>.<name>": add(), register(),
        then update() once per loop iteration (see ParameterBlock)."""
        from ._parameters import ParameterBlock

        return ParameterBlock(self, parameter_group_name, always_publish, topic_name)

    def connect_to_event(
        self, event_name: str, event_md: str, callback: Callable[[Any], object], **connect_args: Any
    ) -> event_connection_wrapper:
        """Connects `callback(event)` to event `event_name` of definition
        `event_md` ("": the interface of the service named `event_name`);
        `connect_args` set the connect fields (for ln.resource_event: the
        fnmatch patterns event_pattern, name_pattern, md_pattern and
        client_pattern). See links_and_nodes._events."""
        from ._events import event_connection_wrapper

        return event_connection_wrapper(self, event_name, event_md, callback, connect_args)


class port_wrapper:
    """A topic port: `packet` holds the message; read() fills it, write() sends it."""

    def __init__(
        self,
        md_name: str,
        packet_class: type,
        port: _ln.OutPort | _ln.InPort,
        client: client,
        topic_name: str,
        need_reliable_transport: bool = False,
    ) -> None:
        self.client = client
        self.topic_name = topic_name
        self.msg_def_name = md_name
        self.msg_def_hash = port.msg_def_hash
        # One wrapper serves both directions (LN 2.9's API): an OutPort or an InPort.
        self.port: Any = port
        self._packet_class = packet_class
        self._packet = packet_class(name=md_name)
        self.need_reliable_transport = need_reliable_transport
        self.timestamp: float = 0
        self.sequence = 0
        self.lost = 0

    @property
    def packet(self) -> Any:
        """The message read() fills and write() sends."""
        return self._packet

    @packet.setter
    def packet(self, value: Any) -> None:
        # Another packet of this port's definition, or exactly one message's
        # bytes (copied in): anything else would only fail in write().
        if isinstance(value, self._packet_class):
            self._packet = value
            return
        size = self._packet._size
        try:
            data = memoryview(value).cast("B")
        except TypeError:
            raise TypeError(
                "port.packet takes a packet of '%s' or a bytes-like object of its %d bytes, not %s"
                % (self.msg_def_name, size, type(value).__name__)
            ) from None
        if data.nbytes != size:
            raise ValueError("port.packet: '%s' messages are %d bytes, got %d" % (self.msg_def_name, size, data.nbytes))
        self._packet._decode(data)

    def read(self, blocking_or_timeout: bool | float = True) -> Any | None:
        """Returns `packet` updated with the next message, or None if there was
        none (False: don't wait; True: wait; a number: wait that many seconds)."""
        port = self.port
        if not port.read(self.packet._buf, blocking_or_timeout):
            return None
        self.timestamp = port.timestamp
        return self.packet

    def write(self, timestamp: float | None = None) -> None:
        """Publishes `packet` (timestamp: seconds, default now)."""
        self.port.write(self.packet._buf, timestamp)

    def has_subscriber(self) -> int:
        return self.port.has_subscriber()

    def has_publisher(self) -> bool:
        return self.port.has_publisher()

    def unblock(self) -> None:
        """Ends a blocking read() in another thread (it raises LNError LNE_PORT_UNBLOCKED)."""
        self.port.unblock()

    @property
    def sample_info(self) -> tuple[int, int, float]:
        """ln_core: (sequence, lost, timestamp) of the last read."""
        return self.port.sequence, self.port.lost, self.port.timestamp

    def borrow(self, blocking_or_timeout: bool | float = True) -> borrowed_packet:
        """ln_core: zero-copy read. A context manager whose value is a read-only
        packet viewing the message in place (arrays are numpy views), or None
        when no message came. Valid until the block ends::

            with port.borrow(1.0) as pkt:
                if pkt is not None:
                    use(pkt.data)
        """
        loan = self.port.borrow(blocking_or_timeout)
        if loan is not None:
            self.timestamp = self.port.timestamp
        return borrowed_packet(self, loan)


class borrowed_packet:
    """Context manager of port_wrapper.borrow()."""

    def __init__(self, port: port_wrapper, loan: Any) -> None:
        self._loan = loan
        self.packet = None if loan is None else port._packet_class(loan, 0, name=port.msg_def_name)
        self.timestamp = port.port.timestamp
        self.sequence = port.port.sequence
        self.lost = port.port.lost

    def __enter__(self) -> Any:
        return self.packet

    def __exit__(self, *exc: object) -> None:
        self.release()

    def memoryview(self) -> memoryview:
        """The whole message as a read-only memoryview (release it before the loan ends)."""
        return memoryview(self._loan)

    def release(self) -> None:
        """Ends the loan (deferred while arrays or memoryviews of it exist)."""
        if self._loan is not None:
            if self.packet is not None:
                self.packet._cache.clear()
                self.packet = None
            self._loan.release()
            self._loan = None


class multi_waiter:
    """Waits until one of several subscribed ports has a new message."""

    def __init__(self, clnt: client) -> None:
        self.client = clnt
        self._native = _ln.MultiWaiter(clnt._native)
        self.ports: list[port_wrapper] = []

    def add_port(self, port: port_wrapper) -> None:
        self._native.add_port(port.port)
        self.ports.append(port)

    def remove_port(self, port: port_wrapper) -> None:
        self._native.remove_port(port.port)
        self.ports.remove(port)

    def wait(self, timeout: float = -1) -> bool:
        """True if a port can be read; False after `timeout` seconds (-1: no limit)."""
        return self._native.wait(float(timeout))

    def can_read(self, port: port_wrapper) -> bool:
        return self._native.can_read(port.port)

    def start_pipe_notifier_thread(self) -> int:
        """A descriptor that becomes readable whenever a port can be read (for
        select()/main loops); acknowledge each with ack_pipe_notification()."""
        return self._native.start_pipe_notifier_thread()

    def ack_pipe_notification(self) -> None:
        self._native.ack_pipe_notification()
