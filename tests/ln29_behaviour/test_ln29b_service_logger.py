"""Service loggers (ln_register_as_service_logger and the generated
ln::log_service_base): lnbt_service_logger compiled against LN 2.9 and
against ln_core, each run against its own system's manager. The transcripts
must be the same: the error cases, then for every logged call the caller's
request item and the provider's response item (fields, flags, the data as
LN 2.9 puts it on the wire, times and ids as relations), nothing for the
excluded service."""

from __future__ import annotations

import lnbt_support as support


def test_service_logger_items_are_the_same(lnbt):
    transcripts = {}
    for system in lnbt.systems():
        program = support.run([system.programs["lnbt_service_logger"], "lnbt.slog"], lnbt.client_env(system))
        assert program.returncode == 0, program.describe()
        # LN 2.9's library logs some failures to stdout, indented.
        transcripts[system.label] = [line for line in program.lines if not line.startswith(" ")]
    assert transcripts["ln_core"] == transcripts["ln29"], (
        "LN 2.9:\n  " + "\n  ".join(transcripts["ln29"]) + "\nln_core:\n  " + "\n  ".join(transcripts["ln_core"])
    )
    ref = transcripts["ln29"]
    assert ref[-1] == "items 6"
    assert (
        sum(
            line.startswith("request from lnbt_log_caller") and "| response from lnbt_log_provider" in line
            for line in ref
        )
        == 3
    )
    assert not any("secret" in line for line in ref if line.startswith("request"))
