"""Main-loop integration (LN 2.9's mainloop=): providers, callers and
multi-waiters driven by one thread's event loop."""

import time

import links_and_nodes as ln
import pytest

DEADLINE = 10.0


def doubling(request, req, resp):
    resp.seq = req.seq
    resp.y = req.x * 2
    request.respond()
    return 0


def test_select_mainloop_runs_timeouts_idles_and_removes_sources():
    loop = ln.SelectMainloop()
    ticks, idles = [], []
    loop.timeout_add(0.01, lambda: ticks.append(1) or len(ticks) < 3)  # repeats until it returns False
    idle = loop.idle_add(lambda: idles.append(1) or True)
    deadline = time.monotonic() + DEADLINE
    while len(ticks) < 3 and time.monotonic() < deadline:
        loop.iterate(True)
    assert len(ticks) == 3 and idles
    assert loop.source_remove(idle) and not loop.source_remove(idle)
    seen = len(idles)
    loop.sleep(0.02)  # the loop runs a while: the removed idle callback would run now
    assert len(idles) == seen and len(ticks) == 3


def test_one_thread_provides_and_calls_through_its_loop(clnt, unique):
    """The classic single-threaded program: its own provider answers while a
    call of the same program waits in the loop."""
    loop = ln.SelectMainloop()
    provider = clnt.get_service_provider("ml.double." + unique, "pytest/small_srv", mainloop=loop)
    provider.set_handler(doubling)
    provider.do_register("ml_group")  # with mainloop=: the loop handles the group
    svc = clnt.get_service("ml.double." + unique, "pytest/small_srv", mainloop=loop)
    for seq in range(3):
        assert svc.call(seq=seq, x=1.5 + seq) is svc
        assert (svc.resp.seq, svc.resp.y) == (seq, 3.0 + 2 * seq)
    assert svc.call_with_timeout(seq=9, x=1.0, timeout=5).resp.y == 2.0


def test_call_via_mainloop_times_out_and_the_loop_keeps_running(clnt, unique):
    loop = ln.SelectMainloop()
    later = []

    def never_now(request, req, resp):
        later.append(request)
        return ln.SVC_RESP_LATER

    provider = clnt.get_service_provider("ml.late." + unique, "pytest/small_srv")
    provider.set_handler(never_now)
    provider.do_register_with_mainloop(loop, "ml_late")
    svc = clnt.get_service("ml.late." + unique, "pytest/small_srv")
    ticks = []
    loop.timeout_add(0.01, lambda: ticks.append(1) or True)
    started = time.monotonic()
    with pytest.raises(ln.LNError, match="timed out") as failure:
        svc.call_via_mainloop(seq=1, x=1.0, _mainloop=loop, _timeout=0.3)
    assert failure.value.code == ln.LNE_SVC_TIMEOUT
    assert 0.25 < time.monotonic() - started < DEADLINE
    assert later and len(ticks) > 5  # the loop ran while the call waited


def test_mainloop_on_async_finish(clnt, unique):
    loop = ln.SelectMainloop()
    provider = clnt.get_service_provider("ml.async." + unique, "pytest/small_srv")
    provider.set_handler(doubling)
    provider.do_register_with_mainloop(loop, "ml_async")
    svc = clnt.get_service("ml.async." + unique, "pytest/small_srv")
    done = []
    svc.call_async(seq=4, x=0.5)
    svc.mainloop_on_async_finish(loop, lambda tag: done.append((tag, svc.resp.y)), "finished")
    deadline = time.monotonic() + DEADLINE
    while not done and time.monotonic() < deadline:
        loop.iterate(True)
    assert done == [("finished", 1.0)]


def test_wrapped_services_with_a_mainloop(clnt, unique):
    loop = ln.SelectMainloop()

    class Provider(ln.service_provider):
        def __init__(self):
            ln.service_provider.__init__(self, clnt, "ml.wrapped." + unique, mainloop=loop)
            self.wrap_service_provider("double", "pytest/small_srv")

        def double(self, seq, x):
            return {"seq": seq, "y": 2 * x}

    class Caller(ln.services_wrapper):
        def __init__(self):
            ln.services_wrapper.__init__(self, clnt, "ml.wrapped." + unique, mainloop=loop)
            self.wrap_service("double", "pytest/small_srv")

    Provider()
    assert Caller().double(seq=5, x=4.0) == {"seq": 5, "y": 8.0}


def test_mainloop_multi_waiter_reads_and_calls_back(clnt, unique):
    from conftest import handshake

    loop = ln.SelectMainloop()
    pub = clnt.publish("ml.topic." + unique, "pytest/p64")
    sub = clnt.subscribe("ml.topic." + unique, "pytest/p64", buffers=8)
    handshake(pub, sub)
    seen = []
    waiter = ln.MainloopMultiWaiter(clnt, loop)
    waiter.add_port(sub, lambda port, tag: seen.append((tag, port.packet.seq)) or port.packet.seq < 3, "t")
    for seq in (1, 2, 3):
        pub.packet.seq = seq
        pub.write()
        deadline = time.monotonic() + DEADLINE
        while len(seen) < seq and time.monotonic() < deadline:
            loop.iterate(True)
    assert seen == [("t", 1), ("t", 2), ("t", 3)]
    pub.packet.seq = 4  # the callback returned False for 3: the port is no longer watched
    pub.write()
    loop.sleep(0.1)  # the loop runs a while: the packet would be seen now
    assert len(seen) == 3
    waiter.stop()


def test_mainloop_must_be_a_mainloop_interface(clnt):
    with pytest.raises(TypeError, match="MainloopInterface"):
        clnt.get_service("ml.x", "pytest/small_srv", mainloop="gobject")


def test_glib_mainloop_needs_pygobject():
    try:
        import gi  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="PyGObject"):
            ln.GLibMainloop()
        return
    loop = ln.GLibMainloop()
    fired = []
    loop.timeout_add(0.01, lambda: fired.append(1) and False)
    deadline = time.monotonic() + DEADLINE
    while not fired and time.monotonic() < deadline:
        loop.sleep(0.05)
    loop.sleep(0.05)  # returning False: it does not fire again
    assert fired == [1]
