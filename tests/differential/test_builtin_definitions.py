"""ln_core's built-in message definitions (ln_core/share/message_definitions:
ln/string, ln/parameters/*, ...) against LN 2.9's files of the same names:
written anew for ln_core (own comments), they must produce the same
"name|hash" and signatures, so that programs of both systems agree on them."""

from __future__ import annotations

import ln_diff_support as support

OUR_BUILTINS = support.REPO_ROOT / "ln_core" / "share" / "message_definitions"


def test_builtins_hash_and_sign_as_ln29s(reference, our_tools, tmp_path):
    ln_dir = reference.share_dir / "links_and_nodes" / "message_definitions"
    ours = support.definitions_below(OUR_BUILTINS)
    shared = [name for name in ours if (ln_dir / name).is_file()]
    assert "ln/parameters/query" in shared and "ln/string" in shared, shared
    env = support.tool_environment(tmp_path)
    headers = {}
    for label, generate, md_dir in (
        ("ln29", reference.ln_generate, ln_dir),
        ("ln_core", our_tools.ln_generate, OUR_BUILTINS),
    ):
        out = tmp_path / f"{label}.h"
        result = support.run([generate, "--md-dir", md_dir, "-f", "-o", out, *shared], env, cwd=tmp_path)
        assert result.returncode == 0, result.describe()
        headers[label] = support.macros(out.read_text())
    wanted = {k: v for k, v in headers["ln29"].items() if k.endswith(("_MD_NAME", "_SIGNATURE"))}
    assert len(wanted) >= len(shared)
    assert {k: headers["ln_core"].get(k) for k in wanted} == wanted
