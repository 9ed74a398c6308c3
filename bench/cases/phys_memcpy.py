"""Physical limit: memcpy bandwidth on one pinned core, warm buffers (bench/probes/memcpy_bw.c).

No reference: this is the ceiling that copying paths (codecs, copying reads) are compared with.
"""

from benchlib import Row

TITLE = "memcpy bandwidth, one core"
ORDER = 10  # physical limits first; library cases use 100 and up

SIZES = [(64, "64 B"), (4096, "4 KiB"), (65536, "64 KiB"), (1 << 20, "1 MiB"), (16 << 20, "16 MiB")]


def run(ctx):
    trials, trial_ms = (3, 40) if ctx.quick else (7, 200)
    cpu = ctx.cpus[0]
    ctx.log(f"memcpy: {len(SIZES)} sizes x {trials} trials on cpu {cpu}")
    results = ctx.run_json(
        [
            ctx.probe("memcpy_bw"),
            "--cpu",
            cpu,
            "--trials",
            trials,
            "--trial-ms",
            trial_ms,
            "--sizes",
            ",".join(str(s) for s, _ in SIZES),
        ],
        timeout=120,
    )
    labels = dict(SIZES)
    for r in results:
        yield Row(
            group="physical: memcpy, 1 core, warm",
            name=f"memcpy {labels.get(r['size'], str(r['size']) + ' B')}",
            metric="bandwidth, best trial",
            unit="GB/s",
            value=r["best_gbps"],
            note=f"median trial {r['median_gbps']:.3g} GB/s, {r['ns_per_copy_median']:.4g} ns/copy, "
            f"{trials} trials, cpu {cpu}",
        )
