"""A plain Cyclone DDS participant (PyPI cyclonedds, no ROS) speaking ROS 2's
conventions by hand: topic rt/<name>, type bridgetest_ln_msgs::msg::dds_::Sample_,
XCDR1. Prints one JSON object per event. Bounded by --duration.

  cyclone_peer.py sub /bt/name [--count N]
  cyclone_peer.py pub /bt/name [--count N] [--rate HZ]
"""

import argparse
import json
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int16, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic


@dataclass
class Sample_(IdlStruct, typename="bridgetest_ln_msgs::msg::dds_::Sample_"):
    seq: uint32
    stamp: float64
    vec: array[float32, 3]
    small: int16
    flags: uint8
    label: array[uint8, 16]


def emit(**event):
    print(json.dumps(event), flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=["sub", "pub"])
    parser.add_argument("name")
    parser.add_argument("--count", type=int, default=10)
    parser.add_argument("--rate", type=float, default=20.0)
    parser.add_argument("--duration", type=float, default=30.0)
    args = parser.parse_args()
    participant = DomainParticipant(0)
    # ROS 2 Jazzy speaks XCDR1 only; reliable to match rclpy's default QoS.
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
        Policy.History.KeepLast(10),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    topic = Topic(participant, "rt" + args.name, Sample_, qos=qos)
    deadline = time.monotonic() + args.duration
    if args.mode == "sub":
        reader = DataReader(participant, topic, qos=qos)
        emit(event="ready")
        got = 0
        while got < args.count and time.monotonic() < deadline:
            for sample in reader.take(N=100):
                got += 1
                emit(
                    event="sample",
                    seq=int(sample.seq),
                    vec=[float(v) for v in sample.vec],
                    small=int(sample.small),
                    flags=int(sample.flags),
                    label=bytes(sample.label).rstrip(b"\0").decode(),
                )
            time.sleep(0.01)
        emit(event="done", received=got)
    else:
        writer = DataWriter(participant, topic, qos=qos)
        emit(event="ready")
        seq = 0
        while seq < args.count and time.monotonic() < deadline:
            label = list(b"cyc%d" % seq)
            writer.write(
                Sample_(
                    seq=seq,
                    stamp=seq * 0.25,
                    vec=[1.0, 2.0, float(seq)],
                    small=-3,
                    flags=7,
                    label=label + [0] * (16 - len(label)),
                )
            )
            seq += 1
            time.sleep(1.0 / args.rate)
        emit(event="done", written=seq)


if __name__ == "__main__":
    main()
