"""What the LN manager knows: its topics (with publisher) and services (with provider),
and when that changes.

LN 2.9's client API has no "list everything" call, so each manager is asked in its
own way:

* ln_core: the client package's introspection API on the bridge's own LN
  connection (client.list_topics() / list_services()). The manager pushes
  publisher and provider changes to every client; availability handlers on the
  names the bridge knows raise `changed`, so the bridge reacts at once. Names it
  has not seen yet show up at its next pass (auto.period).
* LN 2.9's manager serves its GUI over the same port ("GUI\\0" + pickled
  tuples, the protocol of links_and_nodes_base.lnm_remote). We call its
  `get_topics` and `get_clients` and read the pickled objects with stub
  classes, so the manager's own Python package (and Gtk) is not needed. The
  manager pushes notifications on that connection all the time; a reader
  thread drains them and raises `changed` when topics, services or clients
  change, so the bridge reacts at once instead of at its next poll.
"""

import io
import logging
import os
import pickle
import socket
import struct
import threading
import time
from dataclasses import dataclass

log = logging.getLogger("ln_ros2_bridge.ln")


@dataclass(frozen=True)
class LnTopicInfo:
    name: str
    md_name: str
    publisher: str  # client name, "" when the topic has no publisher


@dataclass(frozen=True)
class LnServiceInfo:
    name: str
    interface: str
    provider: str  # client name


class IntrospectionError(Exception):
    pass


def _split_address(address):
    host, _, port = address.rpartition(":")
    return (host or "127.0.0.1"), int(port)


# ---------------------------------------------------------------------------------------------
# LN 2.9: the GUI connection
class _Stub:
    """Any object of the manager's classes: keeps its pickled state as attributes."""

    def __init__(self, *args, **kwargs):
        pass

    def __setstate__(self, state):
        if isinstance(state, tuple) and len(state) == 2:  # (dict, slots) form
            state = {**(state[0] or {}), **(state[1] or {})}
        if isinstance(state, dict):
            self.__dict__.update(state)


class _StubUnpickler(pickle.Unpickler):
    def find_class(self, module, name):
        if module.startswith(("links_and_nodes", "pyutils", "gi", "lnrdb")):
            return type(name, (_Stub,), {})
        return super().find_class(module, name)


class _GuiConnection:
    """One GUI connection to an LN 2.9 manager ("GUI\\0", then u32 size + pickle).

    Both sides keep their pickle memo for the connection's whole life, so an
    object sent a second time arrives as a reference to the first copy: a
    connection shows each manager object as it was when first sent. Snapshots
    therefore use a fresh connection each time (GuiSnapshot)."""

    def __init__(self, address, timeout):
        self._timeout = timeout
        self._sock = socket.create_connection(_split_address(address), timeout=timeout)
        self._sock.sendall(b"GUI\0")
        self._out = io.BytesIO()
        self._pickler = pickle.Pickler(self._out, pickle.HIGHEST_PROTOCOL)
        self._in = io.BytesIO()
        self._unpickler = _StubUnpickler(self._in)
        self._next_id = 0

    def send(self, message):
        self._pickler.dump(message)
        payload = self._out.getvalue()
        self._out.seek(0)
        self._out.truncate()
        self._sock.sendall(struct.pack("I", len(payload)) + payload)

    def receive(self):
        size = struct.unpack("I", self._recv_exact(4))[0]
        self._in.seek(0)
        self._in.truncate()
        self._in.write(self._recv_exact(size))
        self._in.seek(0)
        return self._unpickler.load()

    def _recv_exact(self, n):
        chunks = []
        while n:
            data = self._sock.recv(n)
            if not data:
                raise ConnectionError("LN manager closed the GUI connection")
            chunks.append(data)
            n -= len(data)
        return b"".join(chunks)

    def request(self, method, *args):
        """Calls a manager method (or ("connection", method) of this connection)."""
        self._next_id += 1
        self.send(("proxy", self._next_id, method, args, {}))
        deadline = time.monotonic() + self._timeout
        while True:  # notifications may come first; they are read and dropped
            self._sock.settimeout(max(0.01, deadline - time.monotonic()))
            try:
                message = self.receive()
            except TimeoutError:
                raise IntrospectionError(
                    "LN 2.9 manager did not answer %s within %.1f s" % (method, self._timeout)
                ) from None
            if (
                isinstance(message, tuple)
                and len(message) >= 3
                and message[1] == self._next_id
                and message[0] in ("answer", "exception")
            ):
                break
        if message[0] == "exception":
            raise IntrospectionError("LN 2.9 manager failed %s: %s" % (method, message[2]))
        return message[2]

    def close(self):
        try:
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._sock.close()


class Ln29Introspection:
    """The topics and services of an LN 2.9 manager, read over its GUI port.

    A watcher connection asks only for the notifications that mean "topics,
    services or clients changed" and sets `changed`; topics() and services()
    read a fresh snapshot on a short-lived connection."""

    _CHANGES = ["add_topic", "update_topic", "del_topic", "update_service", "update_client", "del_client"]

    def __init__(self, address, timeout=5.0):
        self.changed = threading.Event()
        self.error = None
        self._address = address
        self._timeout = timeout
        self._closed = False
        self._watcher = _GuiConnection(address, timeout)
        self._watcher.request(("connection", "set_member"), "_enabled_notifications", set(self._CHANGES))
        self._watcher._sock.settimeout(None)
        self._reader = threading.Thread(target=self._watch, name="ln29-gui-watch", daemon=True)
        self._reader.start()

    def _watch(self):
        try:
            while not self._closed:
                message = self._watcher.receive()
                if isinstance(message, tuple) and message and message[0] == "notify":
                    self.changed.set()
        except Exception as error:  # the manager went away (or closed us): the bridge reconnects
            if not self._closed:
                self.error = error
                log.debug("LN 2.9 GUI watcher ended: %s", error)
            self.changed.set()

    def snapshot(self):
        """(topics, services) as the manager sees them now."""
        if self.error is not None:
            raise IntrospectionError("LN 2.9 manager connection lost: %s" % self.error)
        try:
            connection = _GuiConnection(self._address, self._timeout)
        except OSError as error:
            raise IntrospectionError("cannot reach the LN 2.9 manager at %s: %s" % (self._address, error)) from error
        try:
            connection.request(("connection", "set_member"), "_enabled_notifications", set())
            topics = []
            for name, topic in connection.request("get_topics").items():
                publisher = getattr(topic, "publisher", None)
                topics.append(
                    LnTopicInfo(
                        str(name),
                        str(getattr(topic, "md_name", "")),
                        str(getattr(publisher, "program_name", "")) if publisher else "",
                    )
                )
            services = []
            for client in connection.request("get_clients"):
                provider = str(getattr(client, "program_name", ""))
                for name, service in (getattr(client, "provided_services", None) or {}).items():
                    services.append(LnServiceInfo(str(name), str(getattr(service, "interface", "")), provider))
            return topics, services
        except (OSError, EOFError, pickle.UnpicklingError, struct.error) as error:
            raise IntrospectionError("LN 2.9 manager: %s" % error) from error
        finally:
            connection.close()

    def topics(self):
        return self.snapshot()[0]

    def services(self):
        return self.snapshot()[1]

    def definition_file(self, md_name):
        """The file the manager reads a message definition from."""
        connection = _GuiConnection(self._address, self._timeout)
        try:
            connection.request(("connection", "set_member"), "_enabled_notifications", set())
            return str(connection.request("search_message_definition_filename", md_name))
        finally:
            connection.close()

    def close(self):
        self._closed = True
        self._watcher.close()
        self._reader.join(timeout=2.0)


# ---------------------------------------------------------------------------------------------
# ln_core: the client's introspection API
class LnCoreIntrospection:
    """The topics and services of an ln_core manager, asked through an ln_core
    links_and_nodes client. `watch_topics` / `watch_services`: names to watch even
    before the manager lists them (explicit entries)."""

    MAX_WATCHED = 4096  # names per kind; beyond that the ones unlisted longest are let go

    def __init__(self, client, watch_topics=(), watch_services=()):
        if not hasattr(client, "list_topics") or not hasattr(client, "set_publisher_availability_handler"):
            raise IntrospectionError(
                "this ln_core links_and_nodes has no introspection API (client.list_topics()): rebuild ln_core"
            )
        self.changed = threading.Event()
        self.error = None  # (LN 2.9's watcher reports here; ln_core's connection fails ping instead)
        self._client = client
        self._explicit = {"topic": set(watch_topics), "service": set(watch_services)}
        self._watched = {"topic": {}, "service": {}}  # name -> when it was last listed
        self._lock = threading.Lock()
        self._watch("topic", ())
        self._watch("service", ())

    def _on_change(self, name, available):
        self.changed.set()

    def _set_handler(self, kind, name, handler):
        if kind == "topic":
            self._client.set_publisher_availability_handler(name, handler)
        else:
            self._client.set_service_availability_handler(name, handler)

    def _watch(self, kind, listed):
        """Watches the names listed now, the explicit ones, and the ones listed before
        (a publisher or provider that left and comes back is reported too)."""
        now = time.monotonic()
        with self._lock:
            watched = self._watched[kind]
            for name in sorted(set(listed) | self._explicit[kind]):
                if name not in watched:
                    self._set_handler(kind, name, self._on_change)
                watched[name] = now
            if len(watched) > self.MAX_WATCHED:
                for name in sorted(watched, key=watched.get)[: len(watched) - self.MAX_WATCHED]:
                    self._set_handler(kind, name, None)
                    del watched[name]

    def _list(self, method):
        try:
            return getattr(self._client, method)()
        except Exception as error:  # LNError: connection lost, ...
            raise IntrospectionError("ln_core manager: %s: %s" % (method, " ".join(str(error).split()))) from error

    def topics(self):
        return [LnTopicInfo(t.name, t.message_definition.split("|")[0], t.publisher) for t in self._list("list_topics")]

    def services(self):
        return [LnServiceInfo(s.name, s.interface.split("|")[0], s.provider) for s in self._list("list_services")]

    def snapshot(self):
        """(topics, services) as the manager sees them now; from now on changes of
        their publishers and providers raise `changed`."""
        topics, services = self.topics(), self.services()
        try:
            self._watch("topic", [t.name for t in topics])
            self._watch("service", [s.name for s in services])
        except Exception as error:
            raise IntrospectionError(
                "ln_core manager: watching publishers and providers: %s" % " ".join(str(error).split())
            ) from error
        return topics, services

    def close(self):
        with self._lock:
            for kind, names in self._watched.items():
                for name in names:
                    try:
                        self._set_handler(kind, name, None)
                    except Exception:  # the connection may be gone already
                        pass
                names.clear()


def open_introspection(conn, watch_topics=(), watch_services=()):
    """The introspection for an LnConnection's manager."""
    if conn.flavor == "ln29":
        address = conn.manager_address or os.environ.get("LN_MANAGER", "")
        if not address:
            raise IntrospectionError("no LN manager address (ln.manager in the configuration or $LN_MANAGER)")
        return Ln29Introspection(address)
    return LnCoreIntrospection(conn.client, watch_topics, watch_services)
