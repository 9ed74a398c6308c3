"""ln_core: introspection -- what the manager knows about topics, clients,
services and itself (client.list_topics() & co.). Every result is an
immutable NamedTuple; ``._asdict()`` gives a JSON-ready dict."""

from typing import List, NamedTuple

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
    published: List[str]
    #: topic names it subscribes to (sorted)
    subscribed: List[str]
    #: service names it provides (sorted)
    services: List[str]


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
    message_definition_dirs: List[str]


def list_topics(native):
    return [topic_info(**row) for row in _ln.list_topics(native)]


def list_clients(native):
    return [client_info(**row) for row in _ln.list_clients(native)]


def list_services(native):
    return [service_info(**row) for row in _ln.list_services(native)]


def get_manager_status(native):
    return manager_status(**_ln.manager_status(native))
