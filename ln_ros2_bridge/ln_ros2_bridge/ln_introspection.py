"""What the LN manager knows: its topics (with publisher) and services (with provider).

LN's client API has no "list everything" call, so each manager is asked in its
own way:

* ln_core's manager answers `list_topics` / `list_services` (src/protocol/
  methods.hpp). The client package exposes them as client.list_topics() /
  list_services() when available; otherwise we speak the manager's small
  binary protocol on a connection of our own (wire.hpp: u32 size | u8 kind |
  u32 id | u16 n | fields).
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
    publisher: str      # client name, "" when the topic has no publisher


@dataclass(frozen=True)
class LnServiceInfo:
    name: str
    interface: str
    provider: str       # client name


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
        if isinstance(state, tuple) and len(state) == 2:   # (dict, slots) form
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
        while True:   # notifications may come first; they are read and dropped
            self._sock.settimeout(max(0.01, deadline - time.monotonic()))
            try:
                message = self.receive()
            except socket.timeout:
                raise IntrospectionError("LN 2.9 manager did not answer %s within %.1f s"
                                         % (method, self._timeout)) from None
            if isinstance(message, tuple) and len(message) >= 3 and message[1] == self._next_id \
                    and message[0] in ("answer", "exception"):
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
        except Exception as error:   # the manager went away (or closed us): the bridge reconnects
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
                topics.append(LnTopicInfo(str(name), str(getattr(topic, "md_name", "")),
                                          str(getattr(publisher, "program_name", "")) if publisher else ""))
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
# ln_core: list_topics / list_services
_REQUEST, _RESPONSE = 1, 2


def _encode_field(key, value):
    k = key.encode()
    if isinstance(value, bool):
        return struct.pack("<B", len(k)) + k + struct.pack("<BB", 3, int(value))
    if isinstance(value, int):
        return struct.pack("<B", len(k)) + k + struct.pack("<Bq", 1, value)
    data = str(value).encode()
    return struct.pack("<B", len(k)) + k + struct.pack("<BI", 4, len(data)) + data


def _decode_fields(payload):
    kind, msg_id, count = struct.unpack_from("<BIH", payload, 0)
    pos, fields = 7, {}
    for _ in range(count):
        (key_size,) = struct.unpack_from("<B", payload, pos)
        key = payload[pos + 1:pos + 1 + key_size].decode()
        pos += 1 + key_size
        (kind_of_value,) = struct.unpack_from("<B", payload, pos)
        pos += 1
        if kind_of_value == 1:
            (value,) = struct.unpack_from("<q", payload, pos)
            pos += 8
        elif kind_of_value == 2:
            (value,) = struct.unpack_from("<d", payload, pos)
            pos += 8
        elif kind_of_value == 3:
            value = bool(payload[pos])
            pos += 1
        elif kind_of_value == 4:
            (size,) = struct.unpack_from("<I", payload, pos)
            value = payload[pos + 4:pos + 4 + size].decode("utf-8", "replace")
            pos += 4 + size
        elif kind_of_value == 5:
            (n,) = struct.unpack_from("<I", payload, pos)
            pos += 4
            value = []
            for _ in range(n):
                (size,) = struct.unpack_from("<I", payload, pos)
                value.append(payload[pos + 4:pos + 4 + size].decode("utf-8", "replace"))
                pos += 4 + size
        else:
            raise IntrospectionError("ln_core manager sent a field of unknown type %d" % kind_of_value)
        fields[key] = value
    return kind, msg_id, fields


class LnCoreIntrospection:
    """The topics and services of an ln_core manager: through the client package
    when it offers list_topics/list_services, else on a connection of our own."""

    def __init__(self, address, client=None, program_name="ln_ros2_bridge.introspection", timeout=5.0):
        self.changed = threading.Event()   # ln_core pushes nothing here: the bridge polls
        self._client = client if client is not None and hasattr(client, "list_topics") else None
        self._timeout = timeout
        self._sock = None
        self._next_id = 0
        self._lock = threading.Lock()
        if self._client is None:
            self._sock = socket.create_connection(_split_address(address), timeout=timeout)
            self._call("hello", program_name=program_name, pid=os.getpid(), library_version=32)

    def _call(self, method, **fields):
        with self._lock:
            self._next_id += 1
            body = _encode_field("method", method) + b"".join(_encode_field(k, v) for k, v in fields.items())
            payload = struct.pack("<BIH", _REQUEST, self._next_id, 1 + len(fields)) + body
            self._sock.sendall(struct.pack("<I", len(payload)) + payload)
            while True:   # skip notifications until our response
                size = struct.unpack("<I", self._recv_exact(4))[0]
                kind, msg_id, answer = _decode_fields(self._recv_exact(size))
                if kind == _RESPONSE and msg_id == self._next_id:
                    break
        if "error_code" in answer:
            raise IntrospectionError("ln_core manager refused %s: %s" % (method, answer.get("error", "")))
        return answer

    def _recv_exact(self, n):
        chunks = []
        while n:
            data = self._sock.recv(n)
            if not data:
                raise IntrospectionError("ln_core manager closed the connection")
            chunks.append(data)
            n -= len(data)
        return b"".join(chunks)

    def _table(self, method):
        if self._client is not None:
            return getattr(self._client, method)()
        try:
            return self._call(method)
        except (OSError, struct.error) as error:
            raise IntrospectionError("ln_core manager: %s" % error) from error

    def topics(self):
        t = self._table("list_topics")
        if isinstance(t, list):   # the client package's form: a list of dicts
            return [LnTopicInfo(d["name"], d.get("definition", ""), d.get("publisher", "")) for d in t]
        return [LnTopicInfo(n, md.split("|")[0], p)
                for n, md, p in zip(t["names"], t["definitions"], t["publishers"])]

    def snapshot(self):
        return self.topics(), self.services()

    def services(self):
        t = self._table("list_services")
        if isinstance(t, list):
            return [LnServiceInfo(d["name"], d.get("interface", ""), d.get("provider", "")) for d in t]
        return [LnServiceInfo(n, i.split("|")[0], p)
                for n, i, p in zip(t["names"], t["interfaces"], t["providers"])]

    def close(self):
        if self._sock is not None:
            try:
                self._call("goodbye")
            except Exception:
                pass
            self._sock.close()
            self._sock = None


def open_introspection(conn):
    """The introspection for an LnConnection's manager."""
    address = conn.manager_address or os.environ.get("LN_MANAGER", "")
    if not address:
        raise IntrospectionError("no LN manager address (ln.manager in the configuration or $LN_MANAGER)")
    if conn.flavor == "ln29":
        return Ln29Introspection(address)
    return LnCoreIntrospection(address, conn.client)
