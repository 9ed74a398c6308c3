"""Events (ln_event_*, ln::event_connection, the generated
ln::resource_event_base): lnbt_events compiled against LN 2.9 and against
ln_core, each run against its own system's manager; the transcripts must be
the same: the manager's ln.resource_event (initial sync, then a topic's
publisher and subscriber coming and going, delivered in the thread that
handles the default service group), an event another client emits by calling
the connection's handler service (get_buffer, set_data with the right and a
wrong signature, malformed data), and the error cases."""

from __future__ import annotations

import lnbt_support as support


def test_events_behave_the_same(lnbt):
    transcripts = {}
    for system in lnbt.systems():
        program = support.run([system.programs["lnbt_events"], "lnbt.events"], lnbt.client_env(system))
        assert program.returncode == 0, program.describe()
        transcripts[system.label] = program.lines
    assert transcripts["ln_core"] == transcripts["ln29"], (
        "LN 2.9:\n  " + "\n  ".join(transcripts["ln29"]) + "\nln_core:\n  " + "\n  ".join(transcripts["ln_core"])
    )
    ref = transcripts["ln29"]
    assert ref[:3] == [
        "connected id 1",
        "event topic_new_publisher lnbt.events.early lnbt/counter lnbt_ev_other in main thread",
        "event initial_sync_done    in main thread",
    ]
    assert "connected_twice LNE_REQUEST_FAILED" in ref
