"""ln md show | find | generate, through the manager and on the local search path."""

import os

import links_and_nodes as ln
from cli_helpers import ok, ok_json, one_line_error, run_ln, table
from conftest import MSGDEFS


def local_env(manager):
    """No manager at all: definitions come from the local search path."""
    env = manager.env()
    env.pop("LN_MANAGER")
    return env


def test_show_topic_message(manager):
    info = ok_json(run_ln(manager, "md", "show", "pytest/all_types", "--json"))
    with ln.client("cli_md_probe") as probe:
        _, size, md_hash, _ = probe.get_message_definition("pytest/all_types")
    assert (info["name"], info["kind"], info["size"], info["hash"]) == ("pytest/all_types", "message", size, md_hash)
    assert size == 136
    assert info["signature"].startswith("float 4 1,double 8 1,char 1 1,")
    with open(os.path.join(MSGDEFS, "pytest", "all_types")) as f:
        assert info["text"] == f.read()
    assert info["source"] == "ln_manager " + manager.address
    rows = {row["field"]: row for row in info["layout"]["fields"]}
    assert rows["f"] == {"offset": 0, "size": 4, "type": "float", "field": "f"}
    assert rows["vec"] == {"offset": 43, "size": 24, "type": "double[3]", "field": "vec"}
    assert rows["name"]["offset"] == 80 and rows["name"]["type"] == "char[8]"
    assert rows["origin"]["offset"] == 88 and rows["origin.y"]["offset"] == 96
    assert rows["corners[1].y"] == {"offset": 128, "size": 8, "type": "double", "field": "corners[1].y"}

    text = ok(run_ln(manager, "md", "show", "pytest/all_types"))
    assert "definition  pytest/all_types\nkind        message\nsize        136 bytes\nhash        %s" % md_hash in text
    assert "  define point_t as \"point\"\n" in text
    layout = table(text.split("layout:\n", 1)[1])
    assert layout[0] == ["OFFSET", "SIZE", "TYPE", "FIELD"]
    assert ["88", "16", "point_t", "origin"] in layout and ["96", "8", "double", "origin.y"] in layout


def test_show_service(manager):
    info = ok_json(run_ln(manager, "md", "show", "area_service/circle_area", "--json"))
    assert info["kind"] == "service"
    assert info["signature"] == "double 8 1|double 8 1,int32_t 4 1,uint32_t 4 1,char* 1 1"
    assert [r["field"] for r in info["layout"]["response"]] == [
        "area",
        "error_code",
        "error_message_len",
        "error_message",
    ]
    assert info["layout"]["response"][3] == {"offset": 16, "size": 8, "type": "char*", "field": "error_message"}
    assert info["sizes"] == {"request": 8, "response": 24}
    text = ok(run_ln(manager, "md", "show", "area_service/circle_area"))
    assert "layout of the request:" in text and "layout of the response:" in text


def test_show_without_a_manager_uses_the_local_search_path(manager):
    env = local_env(manager)
    info = ok_json(run_ln(None, "md", "show", "counter/count_message", "--md-dir", MSGDEFS, "--json", env=env))
    assert info["source"] == os.path.join(MSGDEFS, "counter", "count_message")
    assert info["size"] == 12 and [r["offset"] for r in info["layout"]["fields"]] == [0, 8]
    env["LN_MESSAGE_DEFINITION_DIRS"] = MSGDEFS
    assert ok_json(run_ln(None, "md", "show", "pytest/point", "--json", env=env))["size"] == 16


def test_show_unknown_definition(manager):
    one_line_error(run_ln(manager, "md", "show", "no/such_md"), "unknown message definition 'no/such_md'", "ln md find")
    one_line_error(run_ln(None, "md", "show", "no/such_md", env=local_env(manager)), "no/such_md")


def test_find(manager):
    hits = {h["name"]: h for h in ok_json(run_ln(manager, "md", "find", "pytest/", "--json"))}
    assert hits["pytest/all_types"]["kind"] == "message" and hits["pytest/echo"]["kind"] == "service"
    assert hits["pytest/point"]["path"] == os.path.join(MSGDEFS, "pytest", "point")
    assert "counter/count_message" not in hits
    rows = table(ok(run_ln(manager, "md", "find", "*_area")))
    assert rows[0] == ["DEFINITION", "KIND", "FILE"]
    assert [r[:2] for r in rows[1:]] == [
        ["area_service/circle_area", "service"],
        ["area_service/ellipse_area", "service"],
        ["area_service/triangle_area", "service"],
    ]
    assert "COUNT" in ok(run_ln(manager, "md", "find", "COUNT")).upper()  # case-insensitive substring
    one_line_error(run_ln(manager, "md", "find", "zzz_nothing"), "no message definition matches 'zzz_nothing'")


def test_find_locally(manager):
    hits = ok_json(run_ln(None, "md", "find", "count", "--md-dir", MSGDEFS, "--json", env=local_env(manager)))
    assert [h["name"] for h in hits] == ["counter/count_message"]


def test_generate_runs_ln_generate(manager):
    header = ok(run_ln(manager, "md", "generate", "--md-dir", MSGDEFS, "-o", "-", "counter/count_message"))
    assert "#define COUNTER_COUNT_MESSAGE_MD_NAME" in header and "counter_count_message_t" in header
    assert "usage: ln_generate" in ok(run_ln(manager, "md", "generate", "--help"))
    failed = run_ln(manager, "md", "generate", "--md-dir", MSGDEFS, "-o", "-", "no/such_md")
    assert failed.returncode != 0 and "Traceback" not in failed.stderr and "no/such_md" in failed.stderr
