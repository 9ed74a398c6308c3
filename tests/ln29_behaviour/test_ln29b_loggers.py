"""Topic loggers (ln_spec ln_logger_*, issue 14): lnbt_logger compiled
against LN 2.9 and against ln_core, each run against its own system's
manager. Where LN 2.9 behaves deterministically the outputs must be equal;
where ln_core differs on purpose (LN 2.9 loses or refuses data there) both
sides are asserted and the difference is reported."""

from __future__ import annotations

import itertools
import struct

import lnbt_support as support

_numbers = itertools.count(1)


def topic(stem: str) -> str:
    return f"lnbt.log.{stem}.{next(_numbers)}"


def logger_run(lnbt, system, *args, timeout=support.PROGRAM_TIMEOUT):
    program = support.run([system.programs["lnbt_logger"], *map(str, args)], lnbt.client_env(system), timeout=timeout)
    assert program.returncode == 0, program.describe()
    return program


def both(lnbt, scenario, *args, work=None):
    """Runs the scenario on both systems; {label: program}. `work`: a
    per-system directory argument appended (and returned) when given."""
    out = {}
    for system in lnbt.systems():
        extra = []
        if work is not None:
            directory = lnbt.work / f"{work}.{next(_numbers)}.{system.label}"
            directory.mkdir()
            extra = [directory]
        out[system.label] = logger_run(lnbt, system, scenario, *args, *extra)
        out[system.label].dir = extra[0] if extra else None
    return out


def without(lines: list[str], *prefixes: str) -> list[str]:
    return [line for line in lines if not line.startswith(prefixes)]


def test_recording_download_divisor_and_reenable_match(lnbt):
    results = {}
    for system in lnbt.systems():
        name = topic("record")
        file = lnbt.work / f"record.{system.label}.lnlog"
        program = logger_run(lnbt, system, "record", name, file)
        results[system.label] = ([line.replace(name, "TOPIC") for line in program.lines], file)
    ours, reference = results["ln_core"][0], results["ln29"][0]
    assert ours == reference, "\n".join(ours) + "\n---- LN 2.9 ----\n" + "\n".join(reference)
    # What LN 2.9 showed, spelled out: the newest 5 of 8, counted from 1;
    # divisor 3 keeps every 3rd since enable; enable starts afresh; 0 means 1.
    assert "same handle yes" in reference and "has_subscriber 0" in reference
    assert "timestamps ok" in reference and "download again same" in reference
    counters = [line.split()[2] for line in reference if line.startswith("sample counter")]
    assert counters[:5] == ["4", "5", "6", "7", "8"]
    assert counters[10:] == ["103", "106", "109", "203", "206", "301", "302", "303"]


def test_files_saved_by_either_system_load_in_the_other(lnbt):
    files = {}
    for system in lnbt.systems():
        file = lnbt.work / f"cross.{system.label}.lnlog"
        logger_run(lnbt, system, "record", topic("cross"), file)
        files[system.label] = file
    loaded = {}
    for system in lnbt.systems():
        for origin, file in files.items():
            program = logger_run(lnbt, system, "load", file)
            loaded[(system.label, origin)] = [
                line.replace(line.split()[1], "TOPIC") if line.startswith("topic ") else line for line in program.lines
            ]
    # Each file reads the same on both systems, and both files hold the same.
    for origin in files:
        assert loaded[("ln_core", origin)] == loaded[("ln29", origin)], origin
    assert loaded[("ln_core", "ln_core")] == loaded[("ln_core", "ln29")]
    assert "deinit OK" in loaded[("ln_core", "ln29")]
    # The layout is LN's: byte order mark, version 3, then our own comment.
    ours, reference = files["ln_core"].read_bytes(), files["ln29"].read_bytes()
    assert ours[:6] == reference[:6] == struct.pack("=HI", 0x0420, 3)


def test_a_topic_published_after_enable_is_recorded(lnbt):
    results = {label: without(p.lines, "init") for label, p in both(lnbt, "later", topic("later")).items()}
    assert results["ln_core"] == results["ln29"]
    assert "recorded consecutive yes last 150" in results["ln29"]


def test_manager_save_writes_lns_raw_and_pcap(lnbt):
    runs = both(lnbt, "save", topic("save"), work="save")
    ours, reference = runs["ln_core"], runs["ln29"]
    # LN 2.9 writes a pickle (it is Python); ln_core refuses, saying why.
    assert "manager_save pickle OK" in reference.lines
    assert "manager_save pickle LNE_REQUEST_FAILED" in ours.lines
    support.DIFFERENCES.append("manager_save 'pickle': LN 2.9 writes a Python pickle, ln_core refuses")
    assert without(ours.lines, "manager_save pickle") == without(reference.lines, "manager_save pickle"), (
        ours.describe() + "\n" + reference.describe()
    )
    assert "manager_save raw OK" in reference.lines and "manager_save pcap OK" in reference.lines
    assert "manager_save raw of two topics LNE_REQUEST_FAILED" in reference.lines
    assert "manager_save unknown LNE_REQUEST_FAILED" in reference.lines
    # pcap: written from the publishers' timestamps, so identical byte for byte.
    for name in ("both.pcap", "auto.pcap"):
        assert (ours.dir / name).read_bytes() == (reference.dir / name).read_bytes(), name
    # raw: the samples; only the recorder's own log_ts (first 8 bytes) differ.
    raw_ours, raw_reference = (ours.dir / "one.raw").read_bytes(), (reference.dir / "one.raw").read_bytes()
    assert len(raw_ours) == len(raw_reference) == 4 * 36
    for i in range(4):
        assert raw_ours[i * 36 + 8 : (i + 1) * 36] == raw_reference[i * 36 + 8 : (i + 1) * 36], i
    assert not (ours.dir / "both.x").exists()


def test_documented_differences(lnbt):
    runs = both(lnbt, "differ", topic("differ"))
    sections = {}
    for label, program in runs.items():
        current = None
        for line in program.lines:
            if line.startswith("-- "):
                current = line[3:]
                sections[(label, current)] = []
            elif current:
                sections[(label, current)].append(line)

    def counters(label, section):
        return [int(line.split()[2]) for line in sections[(label, section)] if line.startswith("sample counter")]

    # A download while recording: LN 2.9 answers with no samples.
    assert counters("ln29", "while enabled") == []
    assert counters("ln_core", "while enabled") == [1, 2, 3]
    support.DIFFERENCES.append("logger download while enabled: LN 2.9 returns no samples, ln_core the samples so far")
    # Timestamps only: LN 2.9's download fails; ln_core gives 20-byte samples.
    assert "download LNE_INTERNAL_ERROR" in sections[("ln29", "only_ts")]
    assert "download OK" in sections[("ln_core", "only_ts")]
    assert any("sample_size 20 " in line for line in sections[("ln_core", "only_ts")])
    support.DIFFERENCES.append("logger set_only_ts: LN 2.9's download fails (LNE_INTERNAL_ERROR), ln_core's works")
    # Two loggers of one topic: LN 2.9 keeps one log per topic, so both get the second's.
    assert counters("ln29", "first") == counters("ln29", "second") == [26, 27, 28]
    assert counters("ln_core", "first") == list(range(21, 29))
    assert counters("ln_core", "second") == [28, 29, 30]
    support.DIFFERENCES.append(
        "two loggers of one topic: LN 2.9 shares one log (the later settings), ln_core records each on its own"
    )


def test_what_a_finished_publisher_wrote_stays_recorded(lnbt):
    results = {}
    for system in lnbt.systems():
        name = topic("exit")
        env = lnbt.client_env(system)
        logger = support.Program([system.programs["lnbt_logger"], "until_eof", name], env, stdin_pipe=True)
        publisher = None
        try:
            assert logger.wait_for_line("enabled", 10) is not None, logger.describe()
            # The publisher writes probes (counter 0) until it is told to go:
            # ln_core's manager starts recording a topic once it tapped the
            # publisher's segment, after publish; what comes before is not
            # recorded. The logger prints "recording" when its download (while
            # enabled) shows a sample. LN 2.9's never does (it returns no
            # samples while enabled; test_documented_differences), and there
            # is no other sign to wait for: its publisher goes at once (what
            # LN 2.9 shows here does not depend on when recording began).
            publisher = support.Program(
                [system.programs["lnbt_publisher"], name, "5", "0.005", "--probe", "10"], env, stdin_pipe=True
            )
            if not system.is_reference:
                assert logger.wait_for_line("recording", 10) is not None, logger.describe() + publisher.describe()
            publisher.tell("go")
            assert publisher.finish() == 0, publisher.describe()
            logger.finish()
        finally:
            logger.kill()
            if publisher:
                publisher.kill()
        # Without the probes (counter 0); the log keeps the newest 100 samples.
        results[system.label] = [
            int(line.split()[2])
            for line in logger.lines
            if line.startswith("sample counter") and line.split()[2] != "0"
        ]
    # LN 2.9's manager cannot find the log once the publisher is gone.
    assert results["ln29"] == []
    assert results["ln_core"] == [1, 2, 3, 4, 5]
    support.DIFFERENCES.append("logger after its publisher exited: LN 2.9 downloads nothing, ln_core the packets")


def test_bad_input(lnbt):
    runs = both(lnbt, "errors", topic("errors"), work="errors")
    lines = {label: without(program.lines, "init") for label, program in runs.items()}
    same = [
        "enable without topics LNE_NO_LOGGER_TOPICS",
        "download never enabled LNE_REQUEST_FAILED",
        "get_topic 1 LNE_TOPIC_ID_OUT_OF_RANGE",
        "save into a missing directory LNE_CHECK_ERRNO",
        "load a missing file LNE_CHECK_ERRNO",
    ]
    for line in same:
        assert line in lines["ln29"] and line in lines["ln_core"], line
    # ln_core refuses earlier and names the problem (LN 2.9 accepts a log size
    # of 0 and an empty name, then fails at enable or records nothing).
    assert "add_topic log_size 0 OK" in lines["ln29"] and "enable LNE_REQUEST_FAILED" in lines["ln29"]
    assert "add_topic log_size 0 LNE_INVALID_PARAMETER" in lines["ln_core"]
    assert "add_topic empty name OK" in lines["ln29"]
    assert "add_topic empty name LNE_INVALID_PARAMETER" in lines["ln_core"]
    assert "enable huge LNE_REQUEST_FAILED" in lines["ln29"] and "enable huge LNE_NO_MEM" in lines["ln_core"]
    assert "load garbage LNE_WRONG_BYTE_ORDER" in lines["ln29"]
    assert "load garbage LNE_INVALID_PARAMETER" in lines["ln_core"]
    support.DIFFERENCES.append(
        "logger bad input: ln_core refuses log size 0 and empty names at add_topic, "
        "a log beyond memory with LNE_NO_MEM, a foreign file with LNE_INVALID_PARAMETER"
    )
