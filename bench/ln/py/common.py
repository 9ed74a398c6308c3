"""What bench/ln/py's programs share (as common.hpp for the C++ ones): the JSON result and error
lines, round-trip statistics and the command line `ROLE [--n N] [--warmup W] [--idle S]
[--max-seconds S] ...`. Imported from the program's own directory, so it runs with LN 2.9's and
with ln_core's links_and_nodes alike."""

import argparse
import json
import sys

import links_and_nodes as ln

STOP = 0xFFFFFFFF


def fail(msg, not_implemented=False):
    print(json.dumps({"ok": False, "error": msg, "not_implemented": not_implemented}), flush=True)
    sys.exit(2)


def rtt_stats(values):
    """n, median, p90, p99, min, max and mean of round trips in us (`values`: sorted)."""

    def q(x):
        return float(values[min(len(values) - 1, int(x * (len(values) - 1) + 0.5))])

    return {
        "n": len(values),
        "median_us": q(0.5),
        "p90_us": q(0.9),
        "p99_us": q(0.99),
        "min_us": float(values[0]),
        "max_us": float(values[-1]),
        "mean_us": float(sum(values)) / len(values),
    }


def main(client_prefix, roles, add_arguments=None):
    """Parses the command line and runs roles[role](client named client_prefix + role, args);
    an error (LN's or ours) becomes an error line, "not_implemented" when it says so."""
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=list(roles))
    if add_arguments is not None:
        add_arguments(ap)
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--idle", type=float, default=20)
    ap.add_argument("--max-seconds", type=float, default=60)
    a = ap.parse_args()
    try:
        clnt = ln.client(client_prefix + a.role)
        roles[a.role](clnt, a)
    except SystemExit:
        raise
    except Exception as e:
        msg = f"{type(e).__name__}: {e}"
        fail(msg, "not yet implemented" in msg.lower() or "NOT_YET_IMPLEMENTED" in msg)
