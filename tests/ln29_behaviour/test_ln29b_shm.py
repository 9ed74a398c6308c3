"""Low-level named shared memory (create_shm_target, read_from_shm_source,
...): lnbt_shm compiled against LN 2.9 and against ln_core. One scripted
process per system must print the same transcript, and segments of version 3
are shared between the systems' processes in both directions (who creates
the segment, who writes and who reads)."""

from __future__ import annotations

import itertools
import os

import lnbt_support as support
import pytest

_numbers = itertools.count(1)


@pytest.fixture
def segment_name():
    """A fresh /dev/shm name; removed afterwards if a program left it behind."""
    name = f"lnbt_shm_{os.getpid()}_{next(_numbers)}"
    yield name
    for leftover in (name, name + "_v4", name + "_magic", name + "_small", name + "_missing"):
        try:
            os.unlink(f"/dev/shm/{leftover}")
        except FileNotFoundError:
            pass


def lines_of(program) -> list[str]:
    # LN 2.9's library logs failures to stdout, indented ("    0.000: ..."),
    # and some bare lines ("could not mmap!"); the probe's lines start with a step.
    return [
        line
        for line in program.lines
        if (line and not line.startswith(" ") and " ret " in line)
        or line.startswith(("lapped", "received", "wrote", "ready"))
    ]


def test_one_process_script_matches(lnbt, segment_name):
    transcripts = {}
    for system in lnbt.systems():
        program = support.run([system.programs["lnbt_shm"], "script", f"{segment_name}_{system.label}", "3"], lnbt.env)
        assert program.returncode == 0, program.describe()
        transcripts[system.label] = lines_of(program)
    lapped = {label: next(line for line in lines if line.startswith("lapped")) for label, lines in transcripts.items()}
    # Deliberate: a reader that fell behind by more than the ring holds
    # continues with the oldest packet still in it (ln_core); LN 2.9
    # continues at its own slot cursor, which depends on its history.
    assert lapped["ln_core"] == "lapped 14 15 16"
    numbers = [int(n) for n in lapped["ln29"].split()[1:]]
    assert numbers == sorted(numbers) and numbers[-1] == 16 and numbers[0] >= 14, lapped
    support.DIFFERENCES.append(
        "raw shm reader lapped by the writer: ln_core continues with the oldest packet in "
        "the ring, LN 2.9 at its slot cursor"
    )
    without_lapped = {
        label: [line for line in lines if not line.startswith("lapped")] for label, lines in transcripts.items()
    }
    assert without_lapped["ln_core"] == without_lapped["ln29"], (
        "LN 2.9:\n  " + "\n  ".join(transcripts["ln29"]) + "\nln_core:\n  " + "\n  ".join(transcripts["ln_core"])
    )
    assert "read_1 ret 1 ts 1.5 counter 1 data 'abcdefghijklmnop'" in without_lapped["ln29"]
    assert without_lapped["ln29"][0] == "v16_features futex 1 glibc_2_25 1 ret -"


@pytest.mark.parametrize("creator", ["reader", "writer"])
def test_segments_are_shared_between_the_systems(lnbt, segment_name, creator):
    count = 100
    for reader_system in lnbt.systems():
        for writer_system in lnbt.systems():
            name = f"{segment_name}_{reader_system.label}_{writer_system.label}"
            where = f"{creator} creates; reader {reader_system}, writer {writer_system}"
            if creator == "reader":
                reader = support.Program(
                    [reader_system.programs["lnbt_shm"], "reader", name, "3", str(count)], lnbt.env
                )
                try:
                    assert reader.wait_for_line("ready", 10) is not None, reader.describe()
                    writer = support.run([writer_system.programs["lnbt_shm"], "writer", name, str(count)], lnbt.env)
                    reader.finish(15)
                finally:
                    reader.kill()
            else:
                writer = support.Program(
                    [writer_system.programs["lnbt_shm"], "writer_create", name, "3", str(count)],
                    lnbt.env,
                    stdin_pipe=True,
                )
                try:
                    assert writer.wait_for_line("ready", 10) is not None, writer.describe()
                    reader = support.Program(
                        [reader_system.programs["lnbt_shm"], "reader_open", name, str(count)], lnbt.env
                    )
                    assert reader.wait_for_line("ready", 10) is not None, reader.describe()
                    writer.proc.stdin.write(b"go\n")
                    writer.proc.stdin.flush()
                    writer.finish(15)
                    reader.finish(15)
                finally:
                    writer.kill()
                    reader.kill()
            assert f"wrote {count}" in writer.lines, where + "\n" + writer.describe()
            assert f"received packets last {count} bad 0" in reader.lines, where + "\n" + reader.describe()
            assert not os.path.exists(f"/dev/shm/{name}"), where + ": the creator removes the segment"
