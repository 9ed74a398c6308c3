"""A service logger in Python (LN 2.9's client.register_as_service_logger):
a Python provider of ln/log_service gets the items of calls between two
other clients."""

import struct
import threading
import time

import links_and_nodes as ln
import pytest


def serve_in_thread(clnt, stop):
    def run():
        while not stop.is_set():
            clnt.wait_and_handle_service_group_requests(None, 0.05)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_python_logger_gets_both_items_of_a_call(manager, unique):
    items = []
    logger = ln.client("py_logger_" + unique)
    provider = ln.client("py_provider_" + unique)
    caller = ln.client("py_caller_" + unique)
    stop = threading.Event()
    try:
        log = logger.get_service_provider("log.%s" % unique, "ln/log_service")

        def on_log(request, req, resp):
            items.append(
                (
                    req.item_type,
                    req.client_name,
                    req.service_name,
                    req.service_interface,
                    req.flags,
                    req.client_id,
                    req.request_id,
                    bytes(req.data),
                )
            )
            request.respond()
            return 0

        log.set_handler(on_log)
        log.do_register()
        logger.register_as_service_logger("log.%s" % unique, "area.%s" % unique)
        area = provider.get_service_provider("area.%s" % unique, "area_service/circle_area")

        def on_area(request, req, resp):
            resp.area = 3 * req.radius**2
            request.respond()
            return 0

        area.set_handler(on_area)
        area.do_register()
        for node in (logger, provider):
            serve_in_thread(node, stop)
        svc = caller.get_service("area.%s" % unique, "area_service/circle_area")
        svc.req.radius = 2.0
        svc.call()
        assert svc.resp.area == 12.0
        deadline = time.time() + 20
        while len(items) < 2 and time.time() < deadline:
            time.sleep(0.02)
        items.sort()
        assert [i[:5] for i in items] == [
            (0, caller.name, "area.%s" % unique, "area_service/circle_area", 2),
            (1, provider.name, "area.%s" % unique, "area_service/circle_area", 0),
        ]
        assert items[0][5:7] == items[1][5:7], "client and request id pair the items"
        request_data, response_data = items[0][7], items[1][7]
        assert struct.unpack_from("<IH", request_data) == (len(request_data), ln.LN_LIBRARY_VERSION)
        assert request_data[14:] == struct.pack("<d", 2.0)
        assert struct.unpack_from("<Ii", response_data) == (len(response_data), 0)
        assert struct.unpack_from("<d", response_data, 8) == (12.0,)
    finally:
        stop.set()
        for clnt in (caller, provider, logger):
            clnt.close()


def test_only_own_services_can_log(clnt, unique):
    with pytest.raises(ln.LNError) as refused:
        clnt.register_as_service_logger("not.mine.%s" % unique, "*")
    assert refused.value.code == ln.LNE_SVC_NOT_REGISTERED
