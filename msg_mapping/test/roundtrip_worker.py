"""Round-trips every type of generated ROS packages through the codecs against rclpy.

Runs in a subprocess whose PYTHONPATH/LD_LIBRARY_PATH include the colcon-built
packages (test_ln_roundtrip.py starts it). For every part of every interface
recorded in the packages' ln_mapping.json, and for `--trials` random messages:

  1. rclpy serialize_message(msg) equals the independent CDR encoder's bytes except at
     padding positions (rclpy leaves padding uninitialized);
  2. codec.ln_to_cdr(LN flat bytes of msg) == the independent CDR bytes exactly, and
     deserialize_message of it == msg;
  3. codec.cdr_to_ln(rclpy's CDR) == the independent LN encoder's bytes, and
     ln_to_cdr(cdr_to_ln(cdr)) == cdr for our own CDR (identity).

Prints one JSON object: {"parts": N, "messages": M, "failures": [...]}.
"""

import argparse
import glob
import json
import os
import sys
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import mm_oracle
from rclpy.serialization import deserialize_message, serialize_message

import msg_mapping


def check_part(codec, pairing, ros_type, ln_name, trials, failures):
    cls = mm_oracle.message_class(ros_type)
    for trial in range(trials):
        rng = mm_oracle.rng_for(ros_type, trial)
        where = f"{ros_type} trial {trial}"
        try:
            msg = mm_oracle.random_message(rng, cls, 0, mm_oracle.opaque_filler(pairing, rng))
            rclpy_cdr = serialize_message(msg)
            oracle_cdr, padding = mm_oracle.cdr_encode(msg)
            # rclpy's message may end with padding: rmw_fastrtps sizes "plain" types rounded up to 4
            # and counts the alignment of empty number sequences that Fast CDR does not write.
            if (
                not mm_oracle.equal_except_padding(rclpy_cdr[: len(oracle_cdr)], oracle_cdr, padding)
                or not len(oracle_cdr) <= len(rclpy_cdr) <= len(oracle_cdr) + 64
            ):
                failures.append(
                    f"{where}: reference CDR encoder disagrees with rclpy: {rclpy_cdr.hex()} vs {oracle_cdr.hex()}"
                )
                continue
            ln = pairing.ln_encode(msg, ln_name)
            ours = codec.ln_to_cdr(ln)
            # Same length as rclpy's, zero padding at the end.
            if ours[: len(oracle_cdr)] != oracle_cdr or len(ours) != len(rclpy_cdr) or any(ours[len(oracle_cdr) :]):
                failures.append(
                    f"{where}: ln_to_cdr {ours.hex()} != expected {oracle_cdr.hex()} "
                    f"(rclpy {rclpy_cdr.hex()}, LN {ln.hex()})"
                )
                continue
            if deserialize_message(ours, cls) != msg:
                failures.append(f"{where}: rclpy reads back a different message")
            back = codec.cdr_to_ln(rclpy_cdr)
            if back != ln:
                failures.append(f"{where}: cdr_to_ln {back.hex()} != expected {ln.hex()}")
            if codec.ln_to_cdr(codec.cdr_to_ln(ours)) != ours:
                failures.append(f"{where}: CDR -> LN -> CDR is not the identity")
            if codec.cdr_size(ln) != len(ours) or codec.ln_size(ours) != len(ln):
                failures.append(f"{where}: size functions disagree")
        except Exception:
            failures.append(f"{where}: {traceback.format_exc(limit=3)}")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--src", required=True, help="directory holding the generated packages")
    p.add_argument("--md-dir", action="append", default=[])
    p.add_argument("--mapping", action="append", default=[], help="further ln_mapping.json files")
    p.add_argument("--trials", type=int, default=20)
    args = p.parse_args()

    documents = []
    for path in sorted(glob.glob(os.path.join(args.src, "*", "ln_mapping.json"))) + args.mapping:
        with open(path, encoding="utf-8") as f:
            documents.append(json.load(f))
    library = msg_mapping.Library(args.md_dir)
    generators = {}  # one per naming configuration (single-package mappings differ)
    failures, parts, definitions = [], 0, 0
    groups = {}
    for doc in documents:
        groups.setdefault(tuple(sorted(doc["naming"].items())), []).append(doc)
    pairings = {key: mm_oracle.Pairing(docs) for key, docs in groups.items()}
    for doc in documents:
        key = tuple(sorted(doc["naming"].items()))
        pairing = pairings[key]
        gen = generators.setdefault(key, msg_mapping.LnToRos(**doc["naming"]))
        for interface in doc["interfaces"]:
            definitions += 1
            gen.add(library, interface["ln_name"])
            for part in ("message", "request", "response", "connect", "call"):
                if part not in interface:
                    continue
                parts += 1
                codec = gen.codec(interface["ln_name"], part)
                check_part(
                    codec, pairing, interface[part]["ros_type"], interface[part]["ln_name"], args.trials, failures
                )
    print(
        json.dumps(
            {
                "definitions": definitions,
                "parts": parts,
                "messages": parts * args.trials,
                "failures": failures[:50],
                "failure_count": len(failures),
            }
        )
    )


if __name__ == "__main__":
    main()
