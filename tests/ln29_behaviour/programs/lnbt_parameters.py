"""Parameters as an LN 2.9 Python script uses them (client.parameter_block(),
client.get_parameters()), run unchanged with LN 2.9's and with ln_core's
links_and_nodes. Prints one line per step ("step: result"); exceptions as
their class for the provider API (ValueError, ...) and as "error" for the
proxy (LN 2.9 raises plain Exception, ln_core LNError). test_ln29b_parameters.py
compares the transcripts."""

import os
import sys
import threading
import time

import links_and_nodes as ln
import numpy as np


def show(value):
    if isinstance(value, np.ndarray):
        return "%s %s %s" % (value.dtype, value.shape, value.tolist())
    return "%s %r" % (type(value).__name__, value)


def step(name, body, proxy_error=False):
    try:
        result = body()
        print("%s: %s" % (name, "ok" if result is None else result), flush=True)
    except Exception as e:
        print("%s: %s" % (name, "error" if proxy_error else type(e).__name__), flush=True)


class Loop:
    def __init__(self, block):
        self.block, self.stop = block, threading.Event()
        self.thread = threading.Thread(target=self.run)
        self.thread.start()

    def run(self):
        while not self.stop.is_set():
            self.block.update()
            time.sleep(0.001)

    def end(self):
        self.stop.set()
        self.thread.join()


def main():
    group = sys.argv[1]
    provider = ln.client("lnbt_py_provider")
    caller = ln.client("lnbt_py_caller")
    block = provider.parameter_block(group)
    seen = []
    after_threads = []
    block.add("gain", 1.5, description="the gain")
    block.add("n", 3)
    block.add("vec", [1.0, 2.0, 3.0])
    block.add("mat", np.arange(6, dtype=np.int16).reshape(2, 3), description="m")
    block.add("flag", True)
    block.add("f32", 0.1, dtype="float32")
    block.add("u8", [0, 255], dtype="uint8")
    block.add(
        "limit",
        5,
        dtype="int32",
        before_update=lambda v: v < 10,
        after_update=lambda v: (seen.append(v), after_threads.append(threading.current_thread())),
    )
    block.add("noout", 2.0, output=False)
    block.add("sub.deep", 0.25)
    print("signals: %s" % ", ".join("%s %s %s" % (block[k].name, block[k].dtype, block[k].shape) for k in block))
    step("add cube", lambda: block.add("cube", np.zeros((2, 2, 2))))
    step("add complex", lambda: block.add("c", 1j))
    step("add int8 300", lambda: block.add("small", 300, dtype="int8"))
    step("add int32 2.5", lambda: block.add("whole", 2.5, dtype="int32"))
    step("add twice", lambda: block.add("gain", 1.0))
    step("update before register", lambda: block.update())
    block.register()
    step("register twice", lambda: block.register())
    step("add after register", lambda: block.add("late", 1))
    out = block.update()
    for name in out.keys():
        print("out %s: %s" % (name, show(out[name])))
    step("update unknown", lambda: block.update(bogus=1))
    step("update wrong shape", lambda: block.update(vec=[1, 2]))
    step("update gain", lambda: show(block.update(gain=2.0).gain))
    step("input in place", lambda: (block.vec.input.__setitem__(0, 9), show(block.update().vec))[1])

    params = caller.get_parameters(group)
    step("names", lambda: sorted(params.get_dict()), proxy_error=True)
    for name in ("gain", "n", "vec", "mat", "flag", "f32", "u8", "limit", "noout"):
        step("read " + name, lambda name=name: show(getattr(params, name)), proxy_error=True)
    step("read sub.deep", lambda: show(params.sub.deep), proxy_error=True)
    step("full gain", lambda: sorted(params.get_dict(full=True)["gain"].items()), proxy_error=True)
    step("item gain", lambda: (params["gain"]["full_name"], params["gain"]["override_enabled"]), proxy_error=True)
    step("contains", lambda: ("gain" in params, "nothere" in params), proxy_error=True)

    loop = Loop(block)
    try:
        step("set gain", lambda: (setattr(params, "gain", 2.5), show(params.gain))[1], proxy_error=True)
        step("set vec", lambda: params.set_override("vec", [4, 5, 6], wait_step=True), proxy_error=True)
        step("set mat", lambda: params.set_override("mat", np.ones((2, 3)), wait_step=True), proxy_error=True)
        step("set flag", lambda: params.set_override("flag", False, wait_step=True), proxy_error=True)
        step("set n fraction", lambda: params.set_override("n", 2.7, wait_step=True), proxy_error=True)
        step("set f32", lambda: params.set_override("f32", 0.5, wait_step=True), proxy_error=True)
        step("set limit", lambda: params.set_override("limit", 7, wait_step=True), proxy_error=True)
        step("set limit refused", lambda: params.set_override("limit", 12, wait_step=True), proxy_error=True)
        step("set noout", lambda: params.set_override("noout", 9.0, wait_step=True), proxy_error=True)
        step("set sub.deep", lambda: params.sub.set_override("deep", 0.75, wait_step=True), proxy_error=True)
        step("set vec wrong size", lambda: params.set_override("vec", [1, 2], wait_step=True), proxy_error=True)
        step("set unknown", lambda: params.set_override("nothere", 1), proxy_error=True)
        step("set u8 300", lambda: params.set_override("u8", [1, 300], wait_step=True), proxy_error=True)
        step("u8 after", lambda: show(params.get_output("u8")), proxy_error=True)
        step(
            "reset gain",
            lambda: (
                params.set_override("gain", None),
                params.set_override("n", 1, wait_step=True),
                show(params.get_output("gain")),
            )[2],
            proxy_error=True,
        )
    finally:
        loop.end()
    for name in ("gain", "vec", "mat", "flag", "n", "f32", "limit", "noout", "sub.deep"):
        step("output " + name, lambda name=name: show(block[name].output))
    step("after_update", lambda: (seen, [t is loop.thread for t in after_threads]))
    step(
        "dict after",
        lambda: sorted((k, show(v)) for k, v in params.get_dict().items() if k not in ("sub", "u8")),
        proxy_error=True,
    )

    step("missing group", lambda: caller.get_parameters("nothing_" + group), proxy_error=True)
    step(
        "allow empty", lambda: caller.get_parameters("nothing_" + group, allow_empty=True).get_dict(), proxy_error=True
    )
    step("exact name", lambda: caller.get_parameters(group + ".gain").get_dict(), proxy_error=True)
    step("root has group", lambda: group in caller.get_parameters("").get_dict(), proxy_error=True)

    os.environ["LN_PARAMETER_PREFIX"] = "pre_%s." % group
    prefixed = provider.parameter_block("pb")
    prefixed.add("x", 1.0)
    prefixed.register()
    prefixed.update()
    step("prefixed via prefix", lambda: caller.get_parameters("pb").get_dict(), proxy_error=True)
    del os.environ["LN_PARAMETER_PREFIX"]
    step("prefixed full name", lambda: caller.get_parameters("pre_%s.pb" % group).get_dict(), proxy_error=True)
    print("done", flush=True)


if __name__ == "__main__":
    main()
