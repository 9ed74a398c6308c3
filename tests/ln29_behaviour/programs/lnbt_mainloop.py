"""One thread, one GLib main loop: a provider, calls of it, the wrapped API
and a MainloopMultiWaiter, all through LN's mainloop= integration. (Not a
call that times out: LN 2.9's call_via_mainloop ignores its timeout and
waits forever; ln_core's raises, see ln_core/python/tests/test_mainloop.py.) Prints one line per observation; run with LN 2.9's Python and
with ln_core's (test_ln29b_mainloop.py compares the transcripts).

Needs PyGObject (the LN 2.9 venv has it). Bounded in time.
"""

import time

import links_and_nodes as ln

SERVICE_MD = "lnbt/echo"
TOPIC_MD = "lnbt/counter"
DEADLINE = 10.0


def reverse(request, req, resp):
    resp.text = req.text[::-1]
    request.respond()
    return 0


def iterate_until(loop, done):
    deadline = time.monotonic() + DEADLINE
    while not done() and time.monotonic() < deadline:
        loop.iterate(True)
    return done()


def main():
    loop = ln.GLibMainloop()
    clnt = ln.client("lnbt_mainloop")

    provider = clnt.get_service_provider("lnbt.ml.reverse", SERVICE_MD, mainloop=loop)
    provider.set_handler(reverse)
    provider.do_register("lnbt_ml")  # the loop handles this group
    svc = clnt.get_service("lnbt.ml.reverse", SERVICE_MD, mainloop=loop)
    for text in ("abc", "main loop"):
        svc.call(text=text, fail=0)
        print("call", text, "->", svc.resp.text, flush=True)
    svc.call_with_timeout(text="timeout given", fail=0, timeout=5)
    print("call_with_timeout ->", svc.resp.text, flush=True)

    class Reverser(ln.service_provider):
        def __init__(self):
            ln.service_provider.__init__(self, clnt, "lnbt.ml.wrapped", mainloop=loop)
            self.wrap_service_provider("reverse", SERVICE_MD)

        def reverse(self, text, fail):
            return text[::-1] if not fail else ""

    class Caller(ln.services_wrapper):
        def __init__(self):
            ln.services_wrapper.__init__(self, clnt, "lnbt.ml.wrapped", mainloop=loop)
            self.wrap_service("reverse", SERVICE_MD)

    Reverser()
    print("wrapped ->", Caller().reverse(text="wrapped", fail=0), flush=True)

    pub = clnt.publish("lnbt.ml.topic", TOPIC_MD)
    sub = clnt.subscribe("lnbt.ml.topic", TOPIC_MD, buffers=8)
    deadline = time.monotonic() + DEADLINE
    while sub.read(0.05) is None and time.monotonic() < deadline:  # the subscription is attached
        pub.write()
    while sub.read(0.1) is not None:
        pass
    seen = []
    waiter = ln.MainloopMultiWaiter(clnt, loop)
    waiter.add_port(sub, lambda port, tag: seen.append((tag, port.packet.counter)) or port.packet.counter < 3, "t")
    for counter in (1, 2, 3):
        pub.packet.counter = counter
        pub.write()
        iterate_until(loop, lambda: len(seen) >= counter)
    print("multi-waiter saw", seen, flush=True)
    waiter.stop()
    print("done", flush=True)


if __name__ == "__main__":
    main()
