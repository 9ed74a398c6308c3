"""Services through the bridge with rclpy clients and servers, both directions:
answers, errors, timeouts and missing peers -- never a hang."""

import time


def _ln_to_ros(timeout=3.0):
    return {
        "services": [
            {"ln": "bt.compute", "ros": "/bt/compute", "type": "bridgetest/compute", "timeout": timeout},
            {"ln": "bt.plain", "ros": "/bt/plain", "type": "bridgetest/plain", "timeout": timeout},
        ]
    }


def _client(ros, srv, name):
    client = ros.node.create_client(srv, name)
    assert client.wait_for_service(timeout_sec=20), "%s never became available" % name
    return client


def _bridge_rcompute(start_bridge, timeout):
    """Bridges the ROS service /bt/rcompute into LN as bt.rcompute, calls timing out after `timeout` s."""
    start_bridge(
        {
            "services": [
                {
                    "ln": "bt.rcompute",
                    "ros": "/bt/rcompute",
                    "type": "bridgetest/compute",
                    "direction": "ros_to_ln",
                    "timeout": timeout,
                }
            ]
        },
        wait=["bridging service bt.rcompute"],
    )


def test_ros_client_calls_ln_provider(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.srv import Compute

    start_bridge(_ln_to_ros(), wait=["bridging service bt.compute"])
    provider = ln_peer("lnsrv", "provide", "bt.compute")
    provider.wait_event("ready")
    client = _client(ros, Compute, "/bt/compute")
    response = ros.call(client, Compute.Request(a=10, values=[1.5, 2.5, 3.0], op="sum"))
    assert (response.result, response.error_code, response.error_message) == (17.0, 0, "ok 3")
    response = ros.call(client, Compute.Request(a=0, values=[], op="max?"))
    assert response.error_code == 3 and "unknown op" in response.error_message  # the provider's own error


def test_ros_client_gets_error_fields_when_ln_provider_missing_or_slow(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.srv import Compute

    bridge = start_bridge(_ln_to_ros(timeout=1.0), wait=["bridging service bt.compute"])
    client = _client(ros, Compute, "/bt/compute")
    start = time.monotonic()
    response = ros.call(client, Compute.Request(a=1, values=[1.0], op="sum"))
    assert response.error_code != 0 and "bt.compute" in response.error_message
    assert time.monotonic() - start < 5
    slow = ln_peer("lnsrv", "provide", "bt.compute", "--mode", "slow", "--delay", 4)
    slow.wait_event("ready")
    start = time.monotonic()
    response = ros.call(client, Compute.Request(a=1, values=[1.0], op="sum"), timeout=10)
    elapsed = time.monotonic() - start
    assert response.error_code != 0 and response.error_message, response
    assert elapsed < 3.5, "the 1 s timeout was not applied (%.1f s)" % elapsed
    assert bridge.running()


def test_response_without_error_fields_is_default_and_logged(ln, start_bridge, ros):
    from bridgetest_ln_msgs.srv import Plain

    bridge = start_bridge(_ln_to_ros(timeout=1.0), wait=["bridging service bt.plain"])
    client = _client(ros, Plain, "/bt/plain")
    response = ros.call(client, Plain.Request(x=21))
    assert response.y == 0
    bridge.wait_log(r"\[ERROR\] .*bt.plain failed.*default response", 10)  # the ROS logger's format


def test_ln_caller_calls_ros_server(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.srv import Compute

    def handle(request, response):
        response.result = sum(request.values) * request.a
        response.error_message = "ros:" + request.op
        return response

    ros.node.create_service(Compute, "/bt/rcompute", handle)
    # (the timeout includes the bridge's wait for DDS discovery of our server: seconds on a busy machine)
    _bridge_rcompute(start_bridge, timeout=10.0)
    caller = ln_peer(
        "lncall", "call", "bt.rcompute", "--request", '{"a": 2, "values": [1, 2, 3.5], "op": "x"}', "--timeout", 15
    )
    (answer,) = caller.wait_event("response", 20)
    assert answer["result"] == 13.0 and answer["error_message"] == "ros:x", answer


def test_ln_caller_gets_error_when_ros_server_missing_or_slow(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.srv import Compute

    _bridge_rcompute(start_bridge, timeout=1.0)
    caller = ln_peer(
        "lncall", "call", "bt.rcompute", "--request", '{"a": 1, "values": [1], "op": "x"}', "--timeout", 30
    )
    (error,) = caller.wait_event("error", 40)
    assert error["elapsed"] < 15, error  # the bridge's answer, not the caller's own 30 s timeout

    def slow(request, response):
        time.sleep(3.0)  # the slow server under test: answers after the bridge's 1 s timeout
        return response

    ros.node.create_service(Compute, "/bt/rcompute", slow)
    for _ in range(10):  # until the bridge has discovered the server: then the call times out
        caller = ln_peer(
            "lncall", "call", "bt.rcompute", "--request", '{"a": 1, "values": [1], "op": "x"}', "--timeout", 10
        )
        (error,) = caller.wait_event("error", 20)
        if error["elapsed"] >= 0.9:
            break
    # An error, not the server's answer (at 3 s), and before the caller's own 10 s timeout: the
    # bridge's 1 s timeout was applied (the upper bound leaves room for a loaded machine).
    assert 0.9 <= error["elapsed"] < 9, "the 1 s timeout was not applied: %s" % error
