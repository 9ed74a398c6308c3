"""The Python API around packets, as LN 2.9 programs use it: client names and
arguments, return values and their types, what a failing call raises (the
builtin exception class and the LNE_ name in its text: LN 2.9's
exceptions carry no code, so programs match that text). One line per
probe, "probe LABEL: RESULT"; run with LN 2.9's Python and with ln_core's (test_ln29b_python_api.py
compares the transcripts).

usage: lnbt_python_api.py   (LN_MANAGER set; bounded in time)
"""

import os
import re
import threading
import time

import links_and_nodes as ln

DEADLINE = 10.0


def kind(value):
    return type(value).__name__


def failure(error):
    import builtins

    classes = [
        c.__name__
        for c in type(error).__mro__
        if getattr(builtins, c.__name__, None) is c and c not in (BaseException, object)
    ]
    code = re.search(r"LNE_[A-Z_]+", str(error))
    return "raises %s %s" % (classes[0] if classes else type(error).__name__, code.group(0) if code else "-")


def probe(label, action):
    try:
        result = action()
    except Exception as error:
        print("probe %s: %s" % (label, failure(error)), flush=True)
        return None
    print("probe %s: %s" % (label, result), flush=True)
    return result


def wait_for(condition):
    deadline = time.monotonic() + DEADLINE
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    return condition()


def main():
    clnt = ln.client("lnbt_api", ["prog", "--some-option", "value", "plain"])
    probe("client name", lambda: clnt.name if isinstance(clnt.name, str) else kind(clnt.name))
    probe("remaining args", lambda: list(clnt.get_remaining_args()))
    address = os.environ["LN_MANAGER"]
    for option in ("--ln-manager", "-ln_manager"):
        probe(
            "arguments with " + option,
            lambda: (lambda c: (c.name, list(c.get_remaining_args())))(
                ln.client("lnbt_api_args", ["prog", option, address, "--keep", "-x"])
            ),
        )
    probe(
        "arguments with the program name",
        lambda: ln.client("lnbt_api_args", ["prog", "--ln-program-name", "renamed_by_argument", "rest"]).name,
    )
    probe("library version", lambda: ln.LN_LIBRARY_VERSION)
    probe("rates", lambda: (ln.RATE_AS_PUBLISHED, ln.RATE_ON_REQUEST_LAST))

    definition, size, md_hash, _flat = clnt.get_message_definition("lnbt/counter")
    probe("definition", lambda: (eval(definition)["fields"], size, len(md_hash)))
    probe("unknown definition", lambda: clnt.get_message_definition("lnbt/no_such_definition"))

    pub = clnt.publish("lnbt.api.topic", "lnbt/counter")
    sub = clnt.subscribe("lnbt.api.topic", "lnbt/counter", buffers=4)
    probe("port attributes", lambda: (pub.topic_name, pub.msg_def_name, len(pub.msg_def_hash), sub.timestamp))
    probe("read before any packet", lambda: sub.read(False))
    wait_for(lambda: pub.has_subscriber() and sub.has_publisher())
    probe("has_subscriber, has_publisher", lambda: (pub.has_subscriber(), sub.has_publisher()))
    deadline = time.monotonic() + DEADLINE
    while sub.read(0.05) is None and time.monotonic() < deadline:
        pub.write()
    while sub.read(0.1) is not None:
        pass
    pub.packet.counter = 7
    pub.write(timestamp=12.5)
    got = sub.read(2.0)
    probe("read with timestamp", lambda: (got is sub.packet, got.counter, sub.timestamp, kind(sub.timestamp)))
    probe("definition for topic", lambda: clnt.get_message_definition_for_topic("lnbt.api.topic")[0])
    other = ln.client("lnbt_api_other")
    probe("second publisher", lambda: other.publish("lnbt.api.topic", "lnbt/counter"))
    probe("subscribe with another definition", lambda: other.subscribe("lnbt.api.topic", "lnbt/other"))
    probe("subscribe with an unknown definition", lambda: other.subscribe("lnbt.api.x", "lnbt/no_such"))

    # services: a provider in a thread of its own client
    provider_client = ln.client("lnbt_api_provider")

    def handler(request, req, resp):
        if req.fail == 1:
            raise RuntimeError("the handler failed")
        if req.fail > 1:
            return req.fail  # an error code, no response
        resp.text = req.text[::-1]
        request.respond()
        return 0

    provider = provider_client.get_service_provider("lnbt.api.echo", "lnbt/echo")
    provider.set_handler(handler)
    provider.do_register("lnbt_api")
    stop = []
    thread = threading.Thread(
        target=lambda: [
            provider_client.wait_and_handle_service_group_requests("lnbt_api", 0.05)
            for _ in iter(lambda: bool(stop), True)
        ],
        daemon=True,
    )
    thread.start()
    try:
        svc = clnt.get_service("lnbt.api.echo", "lnbt/echo")
        probe("call returns the service", lambda: svc.call(text="abc", fail=0) is svc)
        probe("response", lambda: (svc.resp.text, kind(svc.resp.text)))
        probe("call by attribute", lambda: (setattr(svc.req, "text", "xyz"), svc.call().resp.text)[1])
        probe("handler exception", lambda: svc.call(text="a", fail=1))
        probe("handler error code", lambda: svc.call(text="a", fail=5))
        probe("unknown request field", lambda: svc.call(nope=1))
        probe("service without interface", lambda: clnt.get_service("lnbt.api.echo").interface)
        probe("signature", lambda: clnt.get_service_signature("lnbt/echo")[1])
        probe("services with interface", lambda: sorted(clnt.find_services_with_interface("lnbt/echo")))
        probe("unknown service", lambda: clnt.get_service("lnbt.api.nobody", "lnbt/echo").call(text="x", fail=0))
        probe("unknown service without interface", lambda: clnt.get_service("lnbt.api.nobody"))
        probe(
            "async call", lambda: (svc.call_async(text="async", fail=0) is svc, wait_for(svc.finished), svc.resp.text)
        )
    finally:
        stop.append(True)
        thread.join(5)
    print("done", flush=True)


if __name__ == "__main__":
    main()
