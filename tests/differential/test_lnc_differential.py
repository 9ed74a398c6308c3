"""The .lnc language, differentially: generated configs that use defines,
%( ) functions, templates with arguments and defaults, list modifiers on
environments, name prefixes, comments, quotes and ifdef lines are read by
LN 2.9's manager and by ln_core's, and every process must come out with the
same command line and the same environment.

LN 2.9 tells through its console (`dump_startup_commands NAME`, answered by
a manager started with --isolated-test); ln_core through `ln_manager
--check`. Variables that depend on the installation (LD_LIBRARY_PATH,
LN_MESSAGE_DEFINITION_DIRS, LN_MANAGER) are left out of the comparison.
"""

from __future__ import annotations

import random
import re
import shutil
import subprocess
import uuid
from pathlib import Path

import ln_diff_support as support
import ln_testing  # tests/support, on sys.path through conftest.py
import pytest

SEEDS = (1, 2, 3, 4, 5)
PROCESSES_PER_CONFIG = 30
INSTALLATION_DEPENDENT = {"LD_LIBRARY_PATH", "LN_MESSAGE_DEFINITION_DIRS", "LN_MANAGER"}
# ------------------------------------------------------------- generating


class ConfigGenerator:
    """A random but valid .lnc text with PROCESSES_PER_CONFIG processes."""

    WORDS = ["alpha", "beta", "gamma", "delta", "robot", "arm", "base", "x1", "y_2", "path/to/file.txt"]

    def __init__(self, seed: int):
        self.random = random.Random(seed)
        self.lines: list[str] = []
        self.defines: list[str] = []

    def word(self) -> str:
        return self.random.choice(self.WORDS)

    def value(self, depth: int = 0) -> str:
        """Text with replacements LN 2.9 and ln_core must evaluate alike."""
        r = self.random.random()
        if depth > 1 or r < 0.3 or not self.defines:
            return self.word()
        name = self.random.choice(self.defines)
        choices = [
            lambda: "%(" + name + ")",
            lambda: "pre-%(" + name + ")-post",
            lambda: '%(subst "a", "A", "%(' + name + ')")',
            lambda: '%(substring "%(' + name + ')", "1", "3")',
            lambda: '%(length "%(' + name + ')")',
            lambda: "%(strip   %(" + name + ")  )",
            lambda: '%(findstring "ta", "%(' + name + ')")',
            lambda: '%(ifeq "%(' + name + ')", "alpha", "was_alpha", "not_alpha")',
            lambda: '%(ifndef "' + name + '", "never")',
            lambda: '%(ifndef "undefined_define", "fallback")',
            lambda: "%(basename /dir/%(" + name + "))",
            lambda: "%(dirname /dir/%(" + name + ")/leaf)",
            lambda: "%(get_port_from_string %(" + name + "))",
            lambda: '%(env "LN_CORE_LNC_DIFF_VAR", "unset")',
            lambda: '%(env "LN_CORE_LNC_DIFF_UNSET", "default_%(' + name + ')")',
            lambda: '%(twice "' + self.word() + '")',
            lambda: self.value(depth + 1) + "_" + self.value(depth + 1),
        ]
        return self.random.choice(choices)()

    def defines_section(self):
        self.lines.append("defines")
        self.lines.append('twice: %(deffun "w", "%(w)-%(w)")')
        for i in range(6):
            name = "d%d" % i
            self.lines.append("%s: %s" % (name, self.value()))
            self.defines.append(name)
        self.lines.append("simple: robot")
        self.lines.append("robot_name: justin")
        self.lines.append("indirect: %(%(simple)_name)")
        self.defines.append("indirect")
        self.lines.append('hashed: "a#b"')
        self.defines.append("hashed")

    def templates(self):
        self.lines += [
            "template tool(arg, second=default_second)",
            "command: /bin/echo tool %(arg) %(second)",
            "add environment: TOOL_ARG=%(arg)",
            "template env_only()",
            "add environment: FROM_TEMPLATE=%(d1)",
            "append environment PATHLIKE: :/from/template",
            "include parts/included.lnc",
            "add_process_default_template: defaults",
        ]

    def environment(self) -> list[str]:
        r = self.random
        lines = []
        if r.random() < 0.7:
            lines.append("environment: A=%s, B=%s, PATHLIKE=/base" % (self.value(), self.value()))
        ops = [
            lambda: "add environment: C=%s" % self.value(),
            lambda: "add environment: A=%s" % self.value(),
            lambda: "append environment A: _tail",
            lambda: "prepend environment B: head_",
            lambda: "append environment PATHLIKE: :/extra",
            lambda: "prepend environment PATHLIKE: /first:",
            lambda: "remove environment PATHLIKE: /base",
            lambda: "append environment NEW%d: created" % r.randint(0, 3),
            lambda: "environment+: D=%s" % self.value(),
            lambda: "use_template: env_only",
            lambda: "pass_environment: LN_CORE_LNC_DIFF_*",
            lambda: "ifdef d0: add environment: IFDEF=yes",
            lambda: "ifndef undefined_define: add environment: IFNDEF=yes",
            lambda: "ifdef undefined_define: add environment: NEVER=1",
            lambda: "del environment: PATHLIKE=/base",
            lambda: "use_template: included('%s')" % self.value(),
            lambda: "add flags: no_default_templates",
        ]
        for _ in range(r.randint(0, 5)):
            lines.append(r.choice(ops)())
        if r.random() < 0.1:
            lines.insert(r.randint(0, len(lines)), "reset environment:")
        return lines

    def command(self) -> list[str]:
        r = self.random
        kind = r.random()
        if kind < 0.25:
            args = ", ".join(['"%s"' % self.word()] + (["'%s'" % self.word()] if r.random() < 0.5 else []))
            return ["use_template: tool(%s)" % args]
        if kind < 0.4:
            return ['command: "/bin/echo quoted # not a comment %s"' % self.value()]
        if kind < 0.55:
            return ["command: /bin/echo %s # a trailing comment" % self.value()]
        if kind < 0.65:
            return ["command: [", "  /bin/echo multi", "  # a comment line inside", "  %s ]" % self.value()]
        if kind < 0.75:
            return ["command: /bin/echo base", "command+: \" plus %s\"" % self.word()]
        return ["command: /bin/echo %s %s" % (self.value(), self.value())]

    def process(self, index: int):
        self.lines.append("process p%02d_%%(simple)" % index if self.random.random() < 0.2 else "process p%02d" % index)
        self.lines.append("node: localhost")
        body = self.command() + self.environment()
        if self.random.random() < 0.3:
            body.append("flags: no_pty")
        if self.random.random() < 0.2:
            body.append("add flags: start_in_shell")
        self.lines += body

    def generate(self, instance: str) -> str:
        self.lines += ["instance", "name: %s" % instance, "manager: :0", ""]
        self.defines_section()
        self.templates()
        prefix_open = False
        for i in range(PROCESSES_PER_CONFIG):
            if not prefix_open and self.random.random() < 0.15:
                self.lines.append("push_name_prefix: group%d" % i)
                prefix_open = True
            elif prefix_open and self.random.random() < 0.3:
                self.lines.append("pop_name_prefix")
                prefix_open = False
            self.process(i)
        return "\n".join(self.lines) + "\n"


# ---------------------------------------------------------------- reading


def our_startup(ln_manager: Path, config: Path, env) -> dict[str, dict]:
    """name -> {"command": ..., "env": {...}} from `ln_manager --check`."""
    result = support.run([str(ln_manager), "-c", str(config), "--check"], env)
    assert result.returncode in (0, 1), result.stderr
    processes, current = {}, None
    for line in result.stdout.splitlines():
        match = re.match(r"^process (\S+) \(", line)
        if match:
            current = processes.setdefault(match.group(1), {"command": None, "env": {}})
        elif current is not None and line.startswith("  command: "):
            current["command"] = line[len("  command: ") :]
        elif current is not None and line.startswith("  env "):
            name, _, value = line[len("  env ") :].partition("=")
            current["env"][name] = value
    return processes


def ln29_startup(ln_manager: Path, config: Path, names: list[str], env) -> dict[str, dict]:
    """name -> {"command": ..., "env": {...}} from LN 2.9's console."""
    server = ln_testing.Ln29(config.parent, base_env=env, home=Path(env["HOME"]), venv=ln_manager.parent.parent)
    server.log_path = config.with_suffix(".ln29.log")
    try:
        server.start(config=config)
        commands = "".join("dump_startup_commands %s\n" % name for name in names[1:]) + "quit\n"
        console = subprocess.run(
            [str(ln_manager), "--connect", server.address, "--console-exec", "dump_startup_commands %s" % names[0]],
            input=commands,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        server.stop()
    return parse_dumps(console.stdout)


def parse_dumps(text: str) -> dict[str, dict]:
    processes = {}
    parts = re.split(r"_execute_command: \['dump_startup_commands', '([^']+)'\]", text)
    for name, body in zip(parts[1::2], parts[2::2]):
        body = body.split(">>> ")[0]
        lines = re.sub(r"\\\n", "", body).splitlines()  # LN folds long values with "\<newline>"
        env, command = {}, None
        for line in lines:
            if line.startswith("export "):
                key, _, value = line[len("export ") :].partition("=")
                env[key] = value[1:-1] if value.startswith('"') and value.endswith('"') else value
            elif line.strip():
                command = line
        processes[name] = {"command": command, "env": env}
    return processes


# ------------------------------------------------------------------ tests


@pytest.fixture(scope="module")
def managers(reference, our_tools):
    ln29 = reference.venv / "bin" / "ln_manager"
    ours = our_tools.ln_generate.parent / "ln_manager"
    if not ours.is_file():
        ours = Path(shutil.which("ln_manager") or "")
    return support.require(ln29 if ln29.is_file() else None, "LN 2.9's ln_manager"), support.require(
        ours if ours.is_file() else None, "ln_core's ln_manager"
    )


@pytest.mark.parametrize("seed", SEEDS)
def test_processes_start_alike(seed, managers, session_dir, tool_env):
    ln29_manager, our_manager = managers
    work = session_dir / ("lnc_%d" % seed)
    work.mkdir(exist_ok=True)
    config = work / "generated.lnc"
    (work / "parts").mkdir(exist_ok=True)
    (work / "parts" / "included.lnc").write_text(
        "template included(value)\nadd environment: INCLUDED=%(value)@%(CURDIR)\n"
        "template defaults\nadd environment: DEFAULTED=yes\n"
    )
    config.write_text(ConfigGenerator(seed).generate("lnc_diff_%d_%s" % (seed, uuid.uuid4().hex[:6])))
    env = dict(tool_env, LN_CORE_LNC_DIFF_VAR="from_the_environment", LN_CORE_LNC_DIFF_PASSED="passed")
    env.pop("LN_CORE_LNC_DIFF_UNSET", None)
    ours = our_startup(our_manager, config, env)
    assert len(ours) == PROCESSES_PER_CONFIG, "ln_core read %d processes" % len(ours)
    theirs = ln29_startup(ln29_manager, config, sorted(ours), env)
    assert sorted(theirs) == sorted(ours), "LN 2.9 answered for other processes (see %s)" % config
    differences = []
    for name in sorted(ours):
        a, b = theirs[name], ours[name]
        env_a = {k: v for k, v in a["env"].items() if k not in INSTALLATION_DEPENDENT}
        env_b = {k: v for k, v in b["env"].items() if k not in INSTALLATION_DEPENDENT}
        if a["command"] != b["command"]:
            differences.append("%s: command %r (LN 2.9) != %r (ln_core)" % (name, a["command"], b["command"]))
        if env_a != env_b:
            differences.append("%s: environment %r (LN 2.9) != %r (ln_core)" % (name, env_a, env_b))
    assert not differences, "%s\n(config: %s)" % ("\n".join(differences), config)
