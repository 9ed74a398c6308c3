"""Main-loop integration (LN 2.9's ``mainloop=``): services and multi-waiters
driven by a program's own event loop instead of a thread that blocks.

A main loop is any object with LN's MainloopInterface: ``iterate(blocking)``,
``timeout_add(seconds, cb, *args)``, ``idle_add(cb, *args)``,
``fd_add(fd, condition, cb, *args)`` and ``source_remove(source_id)``; a
callback returning a true value stays installed. Two come with the package:
SelectMainloop (select() based, no dependency) and GLibMainloop (a
GLib.MainLoop; needs PyGObject).
"""

from __future__ import annotations

import select
import time
import traceback
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from typing import TypeVar

    from _typeshed import FileDescriptorLike

    from ._client import client, port_wrapper

    _T = TypeVar("_T")

__all__ = ["GLibMainloop", "MainloopInterface", "MainloopMultiWaiter", "SelectMainloop"]


class MainloopInterface:
    """What LN's services and multi-waiters need of a main loop."""

    def run(self) -> None:
        """Runs until quit() is called."""
        self._keep_running = True
        while self._keep_running:
            self.iterate()

    def quit(self) -> None:
        self._keep_running = False

    def iterate(self, blocking: bool = True) -> bool | None:
        """One iteration; blocking: wait until there was an event."""
        raise NotImplementedError()

    def sleep(self, seconds: float) -> None:
        """Runs the loop for `seconds`."""
        waiting = [True]

        def done() -> bool:
            waiting[0] = False
            return False

        self.timeout_add(seconds, done)
        while waiting[0]:
            self.iterate()

    def timeout_add(self, timeout_in_seconds: float, callback: Callable[..., object], *args: Any) -> int:
        """Calls callback(*args) every `timeout_in_seconds`; returns a source id."""
        raise NotImplementedError()

    def idle_add(self, callback: Callable[..., object], *args: Any) -> int:
        """Calls callback(*args) when nothing else is to do; returns a source id."""
        raise NotImplementedError()

    def fd_add(
        self, fd: FileDescriptorLike, condition: str | Iterable[str], callback: Callable[..., object], *args: Any
    ) -> int:
        """Calls callback(*args) when `fd` is ready for `condition` ("in", "out",
        "err" or a sequence of them); returns a source id."""
        raise NotImplementedError()

    def source_remove(self, source_id: int) -> bool | None:
        raise NotImplementedError()


def _conditions(condition: str | Iterable[str]) -> tuple[str, ...]:
    return (condition,) if isinstance(condition, str) else tuple(condition)


def _call(callback: Callable[..., object], args: tuple[Any, ...], what: str) -> object:
    """callback(*args); an exception is reported and removes the source, as
    LN's loops do."""
    try:
        return callback(*args)
    except Exception:
        print("exception in %s callback %r:\n%s" % (what, callback, traceback.format_exc()))
        return False


class SelectMainloop(MainloopInterface):
    """A main loop on select(): timeouts, idle callbacks and descriptors."""

    def __init__(self) -> None:
        self._timeouts: dict[int, list[Any]] = {}  # id -> [deadline, period, callback, args]
        self._idles: dict[int, tuple[Callable[..., object], tuple[Any, ...]]] = {}  # id -> (callback, args)
        # id -> (fd, conditions, callback, args)
        self._watches: dict[int, tuple[int, tuple[str, ...], Callable[..., object], tuple[Any, ...]]] = {}
        self._next_id = 1

    def _new_id(self) -> int:
        source_id, self._next_id = self._next_id, self._next_id + 1
        return source_id

    def timeout_add(self, timeout_in_seconds: float, callback: Callable[..., object], *args: Any) -> int:
        source_id = self._new_id()
        self._timeouts[source_id] = [time.monotonic() + timeout_in_seconds, timeout_in_seconds, callback, args]
        return source_id

    def idle_add(self, callback: Callable[..., object], *args: Any) -> int:
        source_id = self._new_id()
        self._idles[source_id] = (callback, args)
        return source_id

    def fd_add(
        self, fd: FileDescriptorLike, condition: str | Iterable[str], callback: Callable[..., object], *args: Any
    ) -> int:
        source_id = self._new_id()
        fd = fd.fileno() if hasattr(fd, "fileno") else fd
        self._watches[source_id] = (fd, _conditions(condition), callback, args)
        return source_id

    def source_remove(self, source_id: int) -> bool:
        for sources in (self._timeouts, self._idles, self._watches):
            if sources.pop(source_id, None) is not None:
                return True
        return False

    def iterate(self, blocking: bool = True) -> bool:
        timeout: float | None = 0.0
        if blocking and not self._idles:
            deadlines = [entry[0] for entry in self._timeouts.values()]
            timeout = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
        wanted: dict[str, list[int]] = {"in": [], "out": [], "err": []}
        for fd, conditions, _, _ in self._watches.values():
            for condition in conditions:
                if condition in wanted:
                    wanted[condition].append(fd)
        if any(wanted.values()):
            ready = select.select(wanted["in"], wanted["out"], wanted["err"], timeout)
        else:
            if timeout is None:
                raise RuntimeError("SelectMainloop.iterate(): nothing to wait for (no timeouts, no descriptors)")
            time.sleep(timeout)
            ready = ([], [], [])
        handled = self._dispatch_timeouts()
        ready_sets = dict(zip(("in", "out", "err"), map(set, ready)))
        for source_id, (fd, conditions, callback, args) in list(self._watches.items()):
            if source_id in self._watches and any(fd in ready_sets[c] for c in conditions if c in ready_sets):
                handled = True
                if not _call(callback, args, "descriptor"):
                    self._watches.pop(source_id, None)
        if not handled:
            for source_id, (callback, args) in list(self._idles.items()):
                if source_id in self._idles and not _call(callback, args, "idle"):
                    self._idles.pop(source_id, None)
        return handled

    def _dispatch_timeouts(self) -> bool:
        now = time.monotonic()
        handled = False
        for source_id, entry in list(self._timeouts.items()):
            if source_id in self._timeouts and entry[0] <= now:
                handled = True
                if _call(entry[2], entry[3], "timeout"):
                    entry[0] += entry[1]
                else:
                    self._timeouts.pop(source_id, None)
        return handled


def GLibMainloop(context: Any = None, loop: Any = None) -> MainloopInterface:
    """A main loop on GLib (a GLib.MainLoop of `context`, or `loop`). Needs
    PyGObject (``import gi``)."""
    return _glib_mainloop_class()(context, loop)


def _glib_mainloop_class() -> Callable[..., MainloopInterface]:
    try:
        import gi  # type: ignore[import-not-found]  # optional: PyGObject

        gi.require_version("GLib", "2.0")
        from gi.repository import GLib  # type: ignore[import-not-found]
    except (ImportError, ValueError) as error:
        raise ImportError("GLibMainloop needs PyGObject (the 'gi' package with GLib 2.0): %s" % error) from None

    class _GLibMainloop(MainloopInterface):
        default = None

        def __init__(self, context: Any = None, loop: Any = None) -> None:
            self.loop = loop if loop is not None else GLib.MainLoop(context)
            self.ctx = self.loop.get_context()

        def run(self) -> None:
            self.loop.run()

        def quit(self) -> None:
            self.loop.quit()

        def iterate(self, blocking: bool = True) -> bool:
            return self.ctx.iteration(blocking)

        def _attach(self, source: Any, callback: Callable[..., object], args: tuple[Any, ...], what: str) -> int:
            source.set_callback(lambda *ignored: bool(_call(callback, args, what)))
            return source.attach(self.ctx)

        def timeout_add(self, timeout_in_seconds: float, callback: Callable[..., object], *args: Any) -> int:
            return self._attach(GLib.timeout_source_new(int(timeout_in_seconds * 1000)), callback, args, "timeout")

        def idle_add(self, callback: Callable[..., object], *args: Any) -> int:
            return self._attach(GLib.idle_source_new(), callback, args, "idle")

        def fd_add(
            self, fd: FileDescriptorLike, condition: str | Iterable[str], callback: Callable[..., object], *args: Any
        ) -> int:
            flags = {
                "in": GLib.IOCondition.IN,
                "out": GLib.IOCondition.OUT,
                "err": GLib.IOCondition.ERR,
                "hup": GLib.IOCondition.HUP,
            }
            mask = 0
            for c in _conditions(condition):
                mask |= flags[c]
            fd = fd.fileno() if hasattr(fd, "fileno") else fd
            source = GLib.io_create_watch(GLib.IOChannel.unix_new(fd), GLib.IOCondition(mask))
            return self._attach(source, callback, args, "descriptor")

        def source_remove(self, source_id: int) -> None:
            source = self.ctx.find_source_by_id(source_id)
            if source is not None:
                source.destroy()

    return _GLibMainloop


def default_glib_mainloop() -> MainloopInterface:
    """The GLib main loop of the default context (what LN's deprecated
    *_gobject methods integrate with)."""
    cls = _glib_mainloop_class()
    global _default_glib
    if _default_glib is None:
        _default_glib = cls()
    return _default_glib


_default_glib: MainloopInterface | None = None


class MainloopMultiWaiter:
    """Calls cb(port, *args) from the main loop whenever a subscribed port
    has a new packet (read already done). A callback returning a false
    value is removed with its port. Do not read the ports yourself."""

    def __init__(self, client: client, mainloop: MainloopInterface) -> None:
        if not isinstance(mainloop, MainloopInterface):
            raise TypeError(
                "MainloopMultiWaiter: mainloop must be a links_and_nodes.MainloopInterface, not %r" % (mainloop,)
            )
        self.clnt = client
        self.mainloop = mainloop
        self.waiter = client.get_multi_waiter()
        self._ports: list[list[Any]] = []  # [port, (callback, args)]
        self._fd = self.waiter.start_pipe_notifier_thread()
        self._watch: int | None = None

    def add_port(self, port: port_wrapper, cb: Callable[..., object], *cb_args: Any) -> None:
        for entry in self._ports:
            if entry[0] is port:
                entry[1] = (cb, cb_args)
                return
        self.waiter.add_port(port)
        self._ports.append([port, (cb, cb_args)])
        if self._watch is None:
            self._watch = self.mainloop.fd_add(self._fd, "in", self._on_packet)

    def remove_port(self, port: port_wrapper) -> None:
        for i, entry in enumerate(self._ports):
            if entry[0] is port:
                self.waiter.remove_port(port)
                del self._ports[i]
                return
        raise KeyError("port of topic %r is not in this multi-waiter" % getattr(port, "topic_name", port))

    def stop(self) -> None:
        """Removes every port and the main-loop watch."""
        for port, _ in self._ports:
            self.waiter.remove_port(port)
        self._ports = []
        if self._watch is not None:
            self.mainloop.source_remove(self._watch)
            self._watch = None

    def _on_packet(self) -> bool:
        for entry in list(self._ports):
            port, (cb, args) = entry
            if not self.waiter.can_read(port):
                continue
            port.read(False)
            if not _call(cb, (port,) + args, "MainloopMultiWaiter") and entry in self._ports:
                self._ports.remove(entry)
                self.waiter.remove_port(port)
        # After the reads: the notifier thread waits for readable ports again.
        self.waiter.ack_pipe_notification()
        return True


def wait_until(loop: MainloopInterface, done: Callable[[], _T], timeout: float | None = None) -> bool | _T:
    """Iterates `loop` until done() is true; False if `timeout` (seconds)
    passed first."""
    timed_out = [False]
    source = None
    if timeout:

        def expire() -> bool:
            timed_out[0] = True
            return False

        source = loop.timeout_add(timeout, expire)
    while not done() and not timed_out[0]:
        loop.iterate(True)
    if source is not None and not timed_out[0]:
        loop.source_remove(source)
    return not timed_out[0] or done()
