#!/usr/bin/env python3
"""Elevator hardware simulator (ln_spec 7.1), Python; interchangeable with elevator_sim.cpp.

Reads motor commands from elevator03.actors (elevator/actors/motor_control) without
blocking, integrates the car position at a fixed rate, and publishes
elevator03.sensors (elevator/sensors/floor_count) every step, stamped with the
simulation time. Runs until SIGINT/SIGTERM or --duration seconds.

    LN_MANAGER=host:port elevator_sim.py [--floors 10] [--rate 50] [--duration 0]
"""

import argparse
import signal
import sys
import time

import links_and_nodes as ln

AT_FLOOR = 1e-3  # |position - floor| below this counts as level with the floor
SNAP = 0.02  # a stopped car this close to a floor is pulled level (the brakes)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--floors", type=int, default=10)
    parser.add_argument("--rate", type=float, default=50.0, help="steps (and sensor packets) per second")
    parser.add_argument("--duration", type=float, default=0.0, help="seconds; 0 = until a signal")
    args, ln_args = parser.parse_known_args()
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))

    clnt = ln.client("elevator_sim", [sys.argv[0]] + ln_args)
    sensors = clnt.publish("elevator03.sensors", "elevator/sensors/floor_count")
    actors = clnt.subscribe("elevator03.actors", "elevator/actors/motor_control")
    dt = 1.0 / args.rate
    position, sim_time, direction, speed = 0.0, 0.0, 0, 0.0
    print("elevator_sim ready: %d floors, %.0f Hz" % (args.floors, args.rate), flush=True)
    next_step = time.monotonic()
    end = next_step + args.duration if args.duration > 0 else float("inf")
    while not stop and time.monotonic() < end:
        command = actors.read(False)
        if command is not None:
            direction, speed = max(-1, min(1, int(command.direction))), max(0.0, float(command.speed))
        position = min(max(position + direction * speed * dt, 0.0), args.floors - 1.0)
        nearest = round(position)
        if direction == 0 and abs(position - nearest) < SNAP:
            position = float(nearest)
        sim_time += dt
        packet = sensors.packet
        packet.time = sim_time
        packet.position = position
        packet.floor = int(nearest)
        packet.at_floor = 1 if abs(position - nearest) < AT_FLOOR else 0
        sensors.write(sim_time)
        next_step += dt
        time.sleep(max(0.0, next_step - time.monotonic()))
    print("elevator_sim stopped at position %.3f" % position, flush=True)


if __name__ == "__main__":
    main()
