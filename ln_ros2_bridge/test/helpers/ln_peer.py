"""An LN program for the tests, on whichever links_and_nodes is on PYTHONPATH.
Prints one JSON object per event on stdout ("ready" first). Every loop is
bounded by --duration.

  ln_peer.py publish TOPIC [--count N] [--rate HZ] [--wait-subscriber] [--definition sample|joint_state|...]
  ln_peer.py subscribe TOPIC [--count N]
  ln_peer.py provide SERVICE [--mode echo|slow|fail] [--definition compute|plain|elevator]
  ln_peer.py call SERVICE --request JSON [--timeout S] [--definition ...]
"""

import argparse
import json
import os
import sys
import time

import links_and_nodes as ln

DEFS = {
    "sample": "bridgetest/sample",
    "compute": "bridgetest/compute",
    "plain": "bridgetest/plain",
    "elevator": "elevator/request/elevator_call",
    "unmapped": "bridgetest_extra/unmapped",
    "point": "bridgetest_extra/point",
    # derived from standard ROS types (the bridge gives them to the manager)
    "twist": "ros2/geometry_msgs/msg/Twist",
    "joint_state": "ros2/sensor_msgs/msg/JointState",
    "string": "ros2/std_msgs/msg/String",
    "trigger": "ros2/std_srvs/srv/Trigger",
}


def emit(**event):
    print(json.dumps(event), flush=True)


def text_of(value):
    if isinstance(value, bytes):
        return value.rstrip(b"\0").decode()
    return str(value).rstrip("\0")


def sample_dict(packet):
    return {
        "seq": int(packet.seq),
        "stamp": float(packet.stamp),
        "vec": [float(v) for v in packet.vec],
        "small": int(packet.small),
        "flags": int(packet.flags),
        "label": text_of(packet.label),
    }


def fill_joint_state(p, seq):
    names = ["joint_%d" % i for i in range(3)]
    p.header.stamp.sec, p.header.frame_id, p.header.frame_id_len = seq, "base", 4
    p.name_len = p.position_len = len(names)
    for i, name in enumerate(names):
        p.name[i].data, p.name[i].data_len = name, len(name)
        p.position[i] = seq + 0.25 * i


def joint_state_dict(p):
    return {
        "seq": int(p.header.stamp.sec),
        "frame": text_of(p.header.frame_id)[: int(p.header.frame_id_len)],
        "names": [text_of(p.name[i].data)[: int(p.name[i].data_len)] for i in range(int(p.name_len))],
        "position": [float(p.position[i]) for i in range(int(p.position_len))],
    }


def publish(client, args):
    port = client.publish(args.name, DEFS[args.definition], buffers=4)
    deadline = time.monotonic() + args.duration
    if args.wait_subscriber:
        while not port.has_subscriber() and time.monotonic() < deadline:
            time.sleep(0.01)
    emit(event="ready", name=client.name)
    seq = 0
    while seq < args.count and time.monotonic() < deadline:
        p = port.packet
        if args.definition == "joint_state":
            fill_joint_state(p, seq)
        elif args.definition != "point":
            p.seq = seq
        if args.definition == "point":
            p.time = 100.0 + seq * 0.5
            p.pos_mm = [float(seq), 2000.0, -3000.0]
            p.frame = "map"
        if args.definition == "sample":
            p.stamp = time.time()
            p.vec = [seq * 0.5, -1.25, 3.0]
            p.small = -seq
            p.flags = seq % 256
            p.label = "n%d" % seq
        port.write()
        seq += 1
        time.sleep(1.0 / args.rate)
    emit(event="done", written=seq)
    # stay until told to stop (publisher gone is part of some tests)
    while time.monotonic() < deadline and args.linger:
        time.sleep(0.05)


def subscribe(client, args):
    port = client.subscribe(args.name, DEFS[args.definition], buffers=16)
    emit(event="ready", name=client.name)
    got = 0
    deadline = time.monotonic() + args.duration
    while got < args.count and time.monotonic() < deadline:
        packet = port.read(0.2)
        if packet is None:
            continue
        got += 1
        if args.definition == "sample":
            fields = sample_dict(packet)
        elif args.definition == "point":
            fields = {
                "time": float(packet.time),
                "pos_mm": [float(v) for v in packet.pos_mm],
                "frame": text_of(packet.frame),
            }
        elif args.definition == "twist":
            fields = {
                "linear": [float(packet.linear.x), float(packet.linear.y), float(packet.linear.z)],
                "angular_z": float(packet.angular.z),
            }
        elif args.definition == "joint_state":
            fields = joint_state_dict(packet)
        elif args.definition == "string":
            fields = {"data": text_of(packet.data)[: int(packet.data_len)]}
        else:
            fields = {"seq": int(packet.seq)}
        emit(event="packet", **fields)
    emit(event="done", received=got)


def provide(client, args):
    svc = client.get_service_provider(args.name, DEFS[args.definition])

    def handler(request, req, resp):
        if args.mode == "slow":
            time.sleep(args.delay)
        if args.definition == "compute":
            values = [float(v) for v in req.values]
            if args.mode == "fail" or req.op not in ("sum", "max"):
                resp.result = 0.0
                resp.error_code = 3
                resp.error_message = "unknown op %r" % req.op
            else:
                resp.result = float(sum(values) if req.op == "sum" else max(values)) + req.a
                resp.error_code = 0
                resp.error_message = "ok %d" % len(values)
        elif args.definition == "plain":
            resp.y = req.x * 2
        elif args.definition == "trigger":
            resp.success = 1
            resp.message = "triggered in LN by %s" % client.name
        else:
            resp.reached_floor = req.target_floor
            resp.error_code = 0
            resp.error_message = ""
        request.respond()
        emit(event="handled")
        return 0

    svc.set_handler(handler)
    svc.do_register("peer")
    emit(event="ready", name=client.name)
    deadline = time.monotonic() + args.duration
    while time.monotonic() < deadline:
        client.wait_and_handle_service_group_requests("peer", 0.1)


def call(client, args):
    svc = client.get_service(args.name, DEFS[args.definition])
    emit(event="ready", name=client.name)
    request = json.loads(args.request)
    start = time.monotonic()
    try:
        for key, value in request.items():
            setattr(svc.req, key, value)
        svc.call_with_timeout(timeout=args.timeout)
        response = {
            f: getattr(svc.resp, f)
            for f in ("result", "error_code", "error_message", "y", "success", "message")
            if hasattr(svc.resp, f)
        }
        emit(
            event="response",
            elapsed=time.monotonic() - start,
            **{k: (text_of(v) if isinstance(v, (str, bytes)) else float(v)) for k, v in response.items()},
        )
    except Exception as error:
        emit(event="error", elapsed=time.monotonic() - start, error=str(error))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=["publish", "subscribe", "provide", "call"])
    parser.add_argument("name")
    parser.add_argument("--definition", default=None)
    parser.add_argument("--count", type=int, default=100)
    parser.add_argument("--rate", type=float, default=50.0)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--wait-subscriber", action="store_true")
    parser.add_argument("--linger", action="store_true")
    parser.add_argument("--mode", dest="provider_mode", default="echo")
    parser.add_argument("--delay", type=float, default=3.0)
    parser.add_argument("--request", default="{}")
    parser.add_argument("--timeout", type=float, default=5.0)
    parser.add_argument("--client-name", default="peer")
    args = parser.parse_args()
    args.mode, mode = args.provider_mode, args.mode
    if args.definition is None:
        args.definition = "sample" if mode in ("publish", "subscribe") else "compute"
    client = ln.client(args.client_name, os.environ["LN_MANAGER"])
    {"publish": publish, "subscribe": subscribe, "provide": provide, "call": call}[mode](client, args)


if __name__ == "__main__":
    sys.exit(main())
