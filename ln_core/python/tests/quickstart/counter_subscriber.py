#!/usr/bin/env python3
"""Quickstart (topics): prints the counts it receives until the last one."""

import sys
import time

import links_and_nodes as ln

last_count = int(sys.argv[1]) if len(sys.argv) > 1 else 5

clnt = ln.client("counter_subscriber", sys.argv)
port = clnt.subscribe("counter.counts", "counter/count_message", buffers=10)

deadline = time.time() + 20
while time.time() < deadline:
    packet = port.read(1.0)
    if packet is None:
        continue
    age = time.time() - packet.time
    print("count: %d (sent %s)" % (packet.num_counts, "just now" if -1 < age < 5 else "at a strange time"))
    if packet.num_counts >= last_count:
        break
