"""The LN definitions a running LN manager knows, for `ln_ros2_gen --from-manager`:
the definition of every topic and the interface of every service, with the texts
the manager has (what the running system uses, whatever files are on this machine).

Asks the manager through ln_core's links_and_nodes package (client.list_topics(),
client.list_services(), client.get_message_definition_text()).
"""

import re

from ._native import Library, MappingError

_NOT_FOUND = re.compile(r"message definition '([^']+)' not found")
_DEFINE_NOT_FOUND = re.compile(r"(?:<([^>]+)>|\S*):\d+: define refers to '([^']+)', which is neither next to")


def missing_definitions(error):
    """The names under which the definition whose absence made a load fail may be
    known, in LN's resolution order (a define's name next to its importer first);
    [] when the error is about something else. (The error is msg_mapping's
    DefinitionError, or LNError when ln_core's links_and_nodes is loaded too:
    nanobind exception translators are process-wide.)"""
    text = str(error)
    match = _NOT_FOUND.search(text)
    if match:
        return [match.group(1)]
    match = _DEFINE_NOT_FOUND.search(text)
    if not match:
        return []
    importer, quoted = match.groups()
    if importer and "/" in importer:  # an in-memory definition: "<its name>"
        return [importer.rsplit("/", 1)[0] + "/" + quoted, quoted]
    return [quoted]


def load_fetching(load, name, fetch, fetched=None):
    """load(name), where a definition it cannot find (the named one, or one it uses)
    is first fetched: fetch(missing_name) makes it loadable (adds its text or its
    directory) or raises. Each name is fetched at most once (`fetched`, shared between
    calls). Raises the load error when no candidate name could be fetched."""
    fetched = set() if fetched is None else fetched
    while True:
        try:
            return load(name)
        except Exception as error:
            candidates = [c for c in missing_definitions(error) if c not in fetched]
            if not candidates:
                raise
            for candidate in candidates:
                fetched.add(candidate)
                try:
                    fetch(candidate)
                    break
                except Exception:
                    continue
            else:
                raise error


def _first_line(error):
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


class ManagerDefinitions:
    """One connection to an LN manager: which definitions its topics and services
    use (`used_by`: definition -> ["topic a.b", "service c.d", ...]) and a Library
    holding their texts as the manager has them."""

    def __init__(self, address, client_name="ln_ros2_gen"):
        self.address = address
        try:
            import links_and_nodes as ln
        except ImportError as error:
            raise MappingError(
                "--from-manager needs ln_core's links_and_nodes Python package "
                f"(source the workspace's install/setup.bash): {error}"
            ) from None
        if not hasattr(ln.client, "list_topics") or not hasattr(ln.client, "get_message_definition_text"):
            raise MappingError(
                "--from-manager needs ln_core's links_and_nodes with the manager introspection "
                f"API (client.list_topics()); the one found at {ln.__file__} has none"
            )
        try:
            self._client = ln.client(client_name, address)
        except Exception as error:
            raise MappingError(f"--from-manager {address}: cannot reach the LN manager: {_first_line(error)}") from None
        try:
            self.used_by = {}
            for topic in self._client.list_topics():
                self._use(topic.message_definition, f"topic {topic.name}")
            for service in self._client.list_services():
                self._use(service.interface, f"service {service.name}")
        except Exception as error:
            self.close()
            raise MappingError(
                f"--from-manager {address}: the manager's topics and services: {_first_line(error)}"
            ) from None
        self.library = Library()
        self._fetched = set()

    def _use(self, definition, user):
        name = definition.split("|")[0]  # a name may carry its hash
        if name:
            self.used_by.setdefault(name, []).append(user)

    def names(self):
        return sorted(self.used_by)

    def load(self, name):
        """Loads `name` and what it uses into self.library, from the manager."""

        def fetch(missing):
            self.library.add_source(missing, self._client.get_message_definition_text(missing))

        try:
            return load_fetching(self.library.load, name, fetch, self._fetched)
        except Exception as error:
            raise MappingError(
                f"LN definition '{name}' ({', '.join(self.used_by.get(name, []))}) from the "
                f"manager at {self.address}: {_first_line(error)}"
            ) from None

    def close(self):
        client, self._client = getattr(self, "_client", None), None
        if client is not None:
            client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
