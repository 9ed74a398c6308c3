#!/usr/bin/env python3
"""The ROS 2 side of the elevator demo: a plain rclpy node that listens to the
LN elevator's sensors through the bridge and calls its floor-request service.

    ros_listener.py [--samples 25] [--floor 3] [--invalid-floor 42] [--timeout 60]

Exit status 0 when sensor data arrived, the car reached the requested floor
(reached_floor == requested) and an invalid floor was refused with an error.
"""

import argparse
import sys
import threading
import time

import rclpy
from elevator_ln_msgs.msg import SensorsFloorCount
from elevator_ln_msgs.srv import RequestElevatorCall
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=25)
    parser.add_argument("--floor", type=int, default=3)
    parser.add_argument("--invalid-floor", type=int, default=42)
    parser.add_argument("--timeout", type=float, default=60.0)
    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node("elevator_listener")
    samples = []
    node.create_subscription(SensorsFloorCount, "/elevator03/sensors", samples.append, qos_profile_sensor_data)
    client = node.create_client(RequestElevatorCall, "/elevator03/prompt")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    ok = True
    try:
        deadline = time.monotonic() + args.timeout
        while len(samples) < args.samples and time.monotonic() < deadline:
            time.sleep(0.02)  # the executor thread fills `samples`
        if len(samples) < args.samples:
            print("listener: only %d sensor samples within %.0f s" % (len(samples), args.timeout))
            return 1
        first, last = samples[0], samples[args.samples - 1]
        rate = (args.samples - 1) / max(1e-9, last.time - first.time)
        print(
            "listener: %d samples on /elevator03/sensors (simulated %.0f Hz), last: time=%.2f position=%.2f "
            "floor=%d at_floor=%d" % (len(samples), rate, last.time, last.position, last.floor, last.at_floor)
        )
        if not client.wait_for_service(timeout_sec=args.timeout):
            print("listener: /elevator03/prompt not available")
            return 1
        for floor in (args.floor, args.invalid_floor):
            start = time.monotonic()
            future = client.call_async(RequestElevatorCall.Request(target_floor=floor))
            done = threading.Event()
            future.add_done_callback(lambda _: done.set())
            if not done.wait(args.timeout):
                client.remove_pending_request(future)
                print("listener: no answer for floor %d within %.0f s" % (floor, args.timeout))
                return 1
            answer = future.result()
            print(
                "listener: call floor %d -> reached_floor=%d error_code=%d %s(%.1f s)"
                % (
                    floor,
                    answer.reached_floor,
                    answer.error_code,
                    ("'%s' " % answer.error_message) if answer.error_message else "",
                    time.monotonic() - start,
                )
            )
            if floor == args.floor:
                ok &= answer.reached_floor == floor and answer.error_code == 0
                settled = samples[-1]
                print(
                    "listener: sensors now: position=%.3f floor=%d at_floor=%d"
                    % (settled.position, settled.floor, settled.at_floor)
                )
            else:
                ok &= answer.error_code != 0
        print(
            "listener: %s"
            % ("OK: the LN elevator went to floor %d on a ROS 2 service call" % args.floor if ok else "FAILED")
        )
        return 0 if ok else 1
    finally:
        stop.set()
        spinner.join(timeout=5)
        executor.shutdown(timeout_sec=2)
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
