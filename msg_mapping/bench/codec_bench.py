"""Measures msg_mapping's LN <-> CDR codec against rclpy and memcpy (run by msg_mapping_codec.py).

Message: std_msgs/msg/Float64MultiArray with a 64 B / 4 KiB / 1 MiB data payload, as LN topic
packet (ROS -> LN fixed variant: capacities of dim 1, label 8 bytes, data exactly the payload).
Per size, interleaved in every repetition:
  ln_to_cdr        codec, returns new bytes          vs rclpy serialize_message(msg)
  ln_to_cdr_into   codec into a preallocated buffer  vs memcpy of the LN packet (ctypes.memmove,
                                                        same Python call overhead)
  cdr_to_ln        codec, returns new bytes          vs rclpy deserialize_message(cdr)
Each method runs in batches of k calls (k sized to ~5-20 ms); the median per-call time over
the batches is reported. Prints one JSON object per (size, method). Bounded by counts.
"""

import argparse
import array
import ctypes
import json
import os
import statistics
import time


def batch_seconds(fn, k):
    start = time.perf_counter_ns()
    for _ in range(k):
        fn()
    return (time.perf_counter_ns() - start) / 1e9 / k


def calibrate(fn, target_s):
    k = 1
    while True:
        t = batch_seconds(fn, k)
        if t * k >= target_s / 4 or k >= 1 << 20:
            return max(1, int(target_s / max(t, 1e-9)))
        k *= 4


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--sizes", default="64,4096,1048576")
    p.add_argument("--batches", type=int, default=15)
    p.add_argument("--batch-ms", type=float, default=15.0)
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--cpu", type=int, default=-1)
    args = p.parse_args()
    if args.cpu >= 0:
        os.sched_setaffinity(0, {args.cpu})

    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    import msg_mapping

    sizes = [int(s) for s in args.sizes.split(",")]
    setups = {}
    for size in sizes:
        n = size // 8
        ros = msg_mapping.RosToLn(
            msg_mapping.ros_share_dirs(),
            capacities={
                "std_msgs/msg/Float64MultiArray.data": n,
                "std_msgs/msg/MultiArrayLayout.dim": 1,
                "std_msgs/msg/MultiArrayDimension.label": 8,
            },
        )
        ros.add("std_msgs/msg/Float64MultiArray")
        codec = ros.codec("std_msgs/msg/Float64MultiArray")
        msg = Float64MultiArray()
        msg.layout.dim = [MultiArrayDimension(label="x", size=n, stride=n)]
        msg.data = array.array("d", (float(i) for i in range(n)))
        cdr = serialize_message(msg)
        ln = codec.cdr_to_ln(cdr)
        assert len(codec.ln_to_cdr(ln)) == len(cdr)
        assert deserialize_message(codec.ln_to_cdr(ln), Float64MultiArray) == msg
        out = bytearray(len(cdr) + 64)
        ln_copy = ctypes.create_string_buffer(len(ln))
        ln_src = ctypes.create_string_buffer(ln, len(ln))
        setups[size] = {
            "ln_to_cdr": (lambda c=codec, b=ln: c.ln_to_cdr(b)),
            "serialize_message": (lambda m=msg: serialize_message(m)),
            "ln_to_cdr_into": (lambda c=codec, b=ln, o=out: c.ln_to_cdr_into(b, o)),
            "memmove": (lambda d=ln_copy, s=ln_src, k=len(ln): ctypes.memmove(d, s, k)),  # noqa: B008 (bound once, on purpose)
            "cdr_to_ln": (lambda c=codec, b=cdr: c.cdr_to_ln(b)),
            "deserialize_message": (lambda b=cdr: deserialize_message(b, Float64MultiArray)),
            "_bytes": (len(ln), len(cdr)),
        }

    samples = {(size, method): [] for size in sizes for method in setups[sizes[0]] if not method.startswith("_")}
    ks = {}
    for _rep in range(args.reps):
        for size in sizes:
            for method, fn in setups[size].items():
                if method.startswith("_"):
                    continue
                key = (size, method)
                if key not in ks:
                    ks[key] = calibrate(fn, args.batch_ms / 1000)
                for _ in range(max(1, args.batches // args.reps)):
                    samples[key].append(batch_seconds(fn, ks[key]))
    for (size, method), values in samples.items():
        ln_bytes, cdr_bytes = setups[size]["_bytes"]
        per_call = statistics.median(values)
        print(
            json.dumps(
                {
                    "size": size,
                    "method": method,
                    "seconds_per_call": per_call,
                    "calls_per_s": 1.0 / per_call,
                    "ln_bytes": ln_bytes,
                    "cdr_bytes": cdr_bytes,
                    "gbps": ln_bytes / per_call / 1e9,
                    "batches": len(values),
                    "k": ks[(size, method)],
                }
            )
        )


if __name__ == "__main__":
    main()
