"""ln_core: introspection -- what the manager knows about topics, clients,
services and itself (client.list_topics() & co.). Every result is an
immutable NamedTuple; ``._asdict()`` gives a JSON-ready dict."""

from __future__ import annotations

from typing import NamedTuple

from . import _ln


class topic_info(NamedTuple):
    """A topic the manager knows (published or only subscribed)."""

    name: str
    message_definition: str
    hash: str
    message_size: int
    #: client name of the publisher, "" if none
    publisher: str
    #: number of subscriptions
    subscribers: int
    #: packets the publisher wrote, as it last reported (about once per second)
    packets: int
    #: packets per second over the publisher's last report interval; 0 when idle
    rate: float


class client_info(NamedTuple):
    """A client registered with the manager."""

    name: str
    id: int
    pid: int
    #: host name
    host: str
    #: boot id + network namespace: clients with equal ids share memory
    host_id: str
    #: topic names it publishes (sorted)
    published: list[str]
    #: topic names it subscribes to (sorted)
    subscribed: list[str]
    #: service names it provides (sorted)
    services: list[str]


class service_info(NamedTuple):
    """A service registered with the manager."""

    name: str
    #: the service definition name (may carry "|hash")
    interface: str
    signature: str
    #: client name of the provider
    provider: str
    #: its service group, "" for none
    group: str


class manager_status(NamedTuple):
    """The manager itself."""

    version: str
    pid: int
    #: "IP:PORT" it listens on
    address: str
    #: seconds since it started listening
    uptime: float
    clients: int
    topics: int
    services: int
    #: its message-definition search path, in search order
    message_definition_dirs: list[str]


class process_info(NamedTuple):
    """A process, state or group of the manager's config."""

    name: str
    #: "process", "state" or "group"
    kind: str
    #: processes: stopped, starting, started, ready, stopping, restarting,
    #: failed; states: UP, DOWN, unknown, checking, going up, going down,
    #: error; groups: "N/M running"
    state: str
    #: on its way: "start", "stop", "up", "down", "check" or ""
    requested: str
    #: 0 when it does not run
    pid: int
    #: seconds since it started, 0 when it does not run
    uptime: float
    #: automatic restarts so far
    restarts: int
    #: processes: ready; states: UP; groups: every member process runs
    ready: bool
    #: how it ended last ("exit status 3", "killed by SIGKILL"), ""
    last_exit: str
    #: why it failed or cannot start, ""
    error: str
    #: a process's command, a state's check command
    command: str
    #: what it depends on ("a|b": either; "!s": state s DOWN)
    depends_on: list[str]
    #: groups: their processes and states
    members: list[str]


class process_output(NamedTuple):
    """Lines a process or state printed (client.get_process_output())."""

    lines: list[str]
    #: number of lines[0]
    first: int
    #: number of the newest line the manager has (0: none yet); ask again
    #: with after=last to follow
    last: int
    #: lines after `after` the manager no longer keeps
    dropped: int


def list_topics(native: _ln.Client) -> list[topic_info]:
    return [topic_info(**row) for row in _ln.list_topics(native)]


def list_clients(native: _ln.Client) -> list[client_info]:
    return [client_info(**row) for row in _ln.list_clients(native)]


def list_services(native: _ln.Client) -> list[service_info]:
    return [service_info(**row) for row in _ln.list_services(native)]


def get_manager_status(native: _ln.Client) -> manager_status:
    return manager_status(**_ln.manager_status(native))


def list_processes(native: _ln.Client) -> list[process_info]:
    return [process_info(**row) for row in _ln.list_processes(native)]


def control_process(native: _ln.Client, name: str, action: str, alt_command: str | None = None) -> None:
    _ln.control_process(native, name, action, alt_command or "")


def get_process_output(native: _ln.Client, name: str, after: int = 0) -> process_output:
    return process_output(**_ln.process_output(native, name, int(after)))
