#!/usr/bin/env python3
"""Elevator controller (ln_spec 7.1), Python; interchangeable with elevator_control.cpp.

Provides the service elevator03.prompt (elevator/request/elevator_call): drives the
car to the requested floor with motor commands on elevator03.actors, following
elevator03.sensors, and answers with the floor reached. An invalid floor is
answered with error_code 1 and no movement; no sensor data or no arrival in time
with error_code 2. Runs until SIGINT/SIGTERM.

    LN_MANAGER=host:port elevator_control.py [--floors 10] [--move-timeout 30]
"""

import argparse
import signal
import sys
import time

import links_and_nodes as ln

MAX_SPEED = 2.0  # floors per second
ARRIVED = 0.005  # floors


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--floors", type=int, default=10)
    parser.add_argument("--move-timeout", type=float, default=30.0)
    args, ln_args = parser.parse_known_args()
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))

    clnt = ln.client("elevator_control", [sys.argv[0]] + ln_args)
    sensors = clnt.subscribe("elevator03.sensors", "elevator/sensors/floor_count")
    actors = clnt.publish("elevator03.actors", "elevator/actors/motor_control")

    def command(direction, speed):
        actors.packet.direction = direction
        actors.packet.speed = speed
        actors.write()

    def on_call(request, req, resp):
        target = int(req.target_floor)
        resp.error_code, resp.error_message = 0, ""
        if not 0 <= target < args.floors:
            resp.reached_floor = -1
            resp.error_code = 1
            resp.error_message = "invalid floor %d (this building has floors 0..%d)" % (target, args.floors - 1)
            request.respond()
            return 0
        deadline = time.monotonic() + args.move_timeout
        state = None
        while time.monotonic() < deadline and not stop:
            state = sensors.read(1.0) or state
            if state is None:
                break  # no simulator
            distance = target - state.position
            if abs(distance) < ARRIVED and state.at_floor:
                command(0, 0.0)
                break
            # slow down near the target: arrive without overshooting
            command(1 if distance > 0 else -1, min(MAX_SPEED, max(0.05, 4.0 * abs(distance))))
        else:
            command(0, 0.0)
        reached = int(state.floor) if state is not None and state.at_floor else -1
        resp.reached_floor = reached
        if reached != target:
            resp.error_code = 2
            resp.error_message = (
                "no sensor data" if state is None else "did not reach floor %d in %.0f s" % (target, args.move_timeout)
            )
        print("elevator_control: call for floor %d -> %d" % (target, reached), flush=True)
        request.respond()
        return 0

    service = clnt.get_service_provider("elevator03.prompt", "elevator/request/elevator_call")
    service.set_handler(on_call)
    service.do_register()
    print("elevator_control ready", flush=True)
    while not stop:
        clnt.wait_and_handle_service_group_requests(None, 0.5)
    command(0, 0.0)
    print("elevator_control stopped", flush=True)


if __name__ == "__main__":
    main()
