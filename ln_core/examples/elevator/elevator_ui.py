#!/usr/bin/env python3
"""Elevator user interface (ln_spec 7.1): reads floor numbers (from the arguments, or
one per line from stdin), calls elevator03.prompt for each and prints the result.
Input that is not an integer is reported and not sent.

    LN_MANAGER=host:port elevator_ui.py [FLOOR ...] [--timeout 60]
"""

import argparse
import sys

import links_and_nodes as ln


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("floors", nargs="*")
    parser.add_argument("--timeout", type=float, default=60.0)
    args, ln_args = parser.parse_known_args()
    clnt = ln.client("elevator_ui", [sys.argv[0]] + ln_args)
    service = clnt.get_service("elevator03.prompt", "elevator/request/elevator_call")
    failures = 0
    for text in args.floors or (line.strip() for line in sys.stdin):
        try:
            floor = int(text)
        except ValueError:
            print("not a floor number: %r" % text)
            continue
        service.call_with_timeout(target_floor=floor, timeout=args.timeout)
        if service.resp.error_code:
            failures += 1
            print("floor %d: error %d: %s" % (floor, service.resp.error_code, service.resp.error_message))
        else:
            print("floor %d: reached %d" % (floor, service.resp.reached_floor))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
