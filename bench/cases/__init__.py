"""Benchmark cases for bench/run: one module per case, each with TITLE, ORDER and run(ctx).
See bench/README.md, "Adding a case"."""
