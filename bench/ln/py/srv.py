"""Small service round trip with the LN Python binding (`import links_and_nodes as ln`).

    srv.py provide [--name S] [--idle 20]     provider of S.small (lnbench/small_srv)
    srv.py call [--name S] --n N --warmup W   timed calls, every answer checked

The provider answers y = 2 x + seq from wait_and_handle_service_group_requests(None, 0.2);
a call with seq 0xffffffff stops it. Output: one JSON line, like the C++ programs.
"""

import json
import time

import links_and_nodes as ln
from common import STOP, fail, main, rtt_stats


def provide(clnt, a):
    state = {"stop": False, "requests": 0}

    def handler(request, req, resp):
        resp.seq = req.seq
        resp.y = 2 * req.x + req.seq
        request.respond()
        state["requests"] += 1
        if req.seq == STOP:
            state["stop"] = True
        return 0

    svc = clnt.get_service_provider(a.name + ".small", "lnbench/small_srv")
    svc.set_handler(handler)
    svc.do_register()
    print(json.dumps({"ready": True}), flush=True)
    t_start = last_active = time.monotonic()
    seen = 0
    while not state["stop"]:
        clnt.wait_and_handle_service_group_requests(None, 0.2)
        now = time.monotonic()
        if state["requests"] != seen:
            seen, last_active = state["requests"], now
        if now - last_active > a.idle:
            fail(f"provider: no call for {a.idle} s")
        if now - t_start > a.max_seconds:
            fail("provider: no stop call within max-seconds")
    print(json.dumps({"ok": True, "test": "py_provider", "requests": state["requests"]}), flush=True)


def call(clnt, a):
    svc = clnt.get_service(a.name + ".small", "lnbench/small_srv")
    clock = time.perf_counter
    rtt = []
    t_start = time.monotonic()
    for i in range(a.warmup + a.n):
        if time.monotonic() - t_start > a.max_seconds:
            fail(f"calls took longer than {a.max_seconds} s")
        x = 0.5 * i
        svc.req.seq = i
        svc.req.x = x
        t0 = clock()
        svc.call()
        t1 = clock()
        if svc.resp.seq != i or svc.resp.y != 2 * x + i:
            fail(f"wrong answer to call {i}: seq {svc.resp.seq}, y {svc.resp.y}")
        if i >= a.warmup:
            rtt.append((t1 - t0) * 1e6)
    svc.req.seq = STOP
    svc.req.x = 0.0
    svc.call()
    rtt.sort()
    print(
        json.dumps(
            {
                "ok": True,
                "test": "py_srv_rtt",
                **rtt_stats(rtt),
                "seconds": time.monotonic() - t_start,
                "ln_module": ln.__file__,
            }
        ),
        flush=True,
    )


if __name__ == "__main__":
    main(
        "lnbench_pysrv_",
        {"provide": provide, "call": call},
        lambda ap: ap.add_argument("--name", default="lnbench.pysrv"),
    )
