#!/usr/bin/env python3
"""Quickstart (topics): publishes counts 1..N on counter.counts at 10 Hz."""

import sys
import time

import links_and_nodes as ln

n_counts = int(sys.argv[1]) if len(sys.argv) > 1 else 5

clnt = ln.client("counter_publisher", sys.argv)
port = clnt.publish("counter.counts", "counter/count_message")

while not port.has_subscriber():  # nobody listens yet
    time.sleep(0.05)
time.sleep(0.5)  # let the subscriber attach before the first count

for count in range(1, n_counts + 1):
    port.packet.time = time.time()
    port.packet.num_counts = count
    port.write()
    time.sleep(0.1)
print("published %d counts" % n_counts)
