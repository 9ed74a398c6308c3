"""Small service round trip with the LN Python binding (`import links_and_nodes as ln`).

    srv.py provide [--name S] [--idle 20]     provider of S.small (lnbench/small_srv)
    srv.py call [--name S] --n N --warmup W   timed calls, every answer checked

The provider answers y = 2 x + seq from wait_and_handle_service_group_requests(None, 0.2);
a call with seq 0xffffffff stops it. Output: one JSON line, like the C++ programs.
"""

import argparse
import json
import sys
import time

import links_and_nodes as ln

STOP = 0xFFFFFFFF


def fail(msg, not_implemented=False):
    print(json.dumps({"ok": False, "error": msg, "not_implemented": not_implemented}), flush=True)
    sys.exit(2)


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

    def q(x):
        return rtt[min(len(rtt) - 1, int(x * (len(rtt) - 1) + 0.5))]

    print(
        json.dumps(
            {
                "ok": True,
                "test": "py_srv_rtt",
                "n": len(rtt),
                "median_us": q(0.5),
                "p90_us": q(0.9),
                "p99_us": q(0.99),
                "min_us": rtt[0],
                "max_us": rtt[-1],
                "mean_us": sum(rtt) / len(rtt),
                "seconds": time.monotonic() - t_start,
                "ln_module": ln.__file__,
            }
        ),
        flush=True,
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["provide", "call"])
    ap.add_argument("--name", default="lnbench.pysrv")
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--idle", type=float, default=20)
    ap.add_argument("--max-seconds", type=float, default=60)
    a = ap.parse_args()
    try:
        clnt = ln.client("lnbench_pysrv_" + a.role)
        (provide if a.role == "provide" else call)(clnt, a)
    except SystemExit:
        raise
    except Exception as e:
        msg = f"{type(e).__name__}: {e}"
        fail(msg, "not yet implemented" in msg.lower() or "NOT_YET_IMPLEMENTED" in msg)


if __name__ == "__main__":
    main()
