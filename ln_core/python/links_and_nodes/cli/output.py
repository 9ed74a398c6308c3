"""How `ln` prints: aligned tables, YAML-like records, JSON, colour on terminals only."""

import json
import math
import os
import sys

_CODES = {"bold": "1", "dim": "2", "red": "31", "green": "32", "yellow": "33", "cyan": "36"}


def colour_wanted(choice, stream):
    """--color auto|always|never; auto: a terminal, and NO_COLOR unset."""
    if choice == "always":
        return True
    if choice == "never":
        return False
    return bool(stream.isatty()) and not os.environ.get("NO_COLOR") and os.environ.get("TERM") != "dumb"


class Output:
    """Everything `ln` writes to stdout goes through here."""

    def __init__(self, json_mode=False, colour="auto", stream=None):
        self.stream = stream or sys.stdout
        self.json_mode = json_mode
        self.colour = colour_wanted(colour, self.stream)

    def paint(self, text, style):
        if not self.colour or not style:
            return text
        return "\033[%sm%s\033[0m" % (";".join(_CODES[s] for s in style.split()), text)

    def line(self, text=""):
        self.stream.write(text + "\n")

    def flush(self):
        self.stream.flush()

    def json(self, data, compact=False):
        self.line(to_json(data, compact))

    def table(self, headers, rows, numeric=(), empty=None):
        """Columns padded to the widest cell; `numeric` columns align right."""
        if not rows:
            if empty:
                self.line(self.paint(empty, "dim"))
            return
        cells = [[_cell(value) for value in row] for row in rows]
        widths = [max(len(headers[i]), *(len(row[i]) for row in cells)) for i in range(len(headers))]

        def fmt(row, style=None):
            parts = []
            for i, text in enumerate(row):
                last = i == len(row) - 1
                padded = text.rjust(widths[i]) if i in numeric else (text if last else text.ljust(widths[i]))
                parts.append(self.paint(padded, style) if style else padded)
            return "  ".join(parts).rstrip()

        self.line(fmt(headers, "bold"))
        for row in cells:
            self.line(fmt(row))

    def fields(self, pairs):
        """'key   value' lines with aligned values."""
        width = max((len(key) for key, _ in pairs), default=0)
        for key, value in pairs:
            self.line("%s  %s" % (self.paint(key.ljust(width), "bold"), _cell(value)))

    def record(self, plain, max_array=0):
        """Plain data (dicts, lists, scalars) in YAML's block style."""
        for text in yaml_lines(plain, max_array, self.paint):
            self.line(text)


def _cell(value):
    if value is None:
        return "-"
    if isinstance(value, (list, tuple)):
        return ", ".join(str(v) for v in value) if value else "-"
    if isinstance(value, float):
        return format_number(value)
    return str(value)


def format_number(value):
    """Numbers for people: a double to 15 significant digits, so that 0.1 * 29
    shows as 2.9 and not 2.9000000000000004 (--json and --csv keep every digit)."""
    if not isinstance(value, float):
        return str(value)
    if math.isnan(value) or math.isinf(value):
        return repr(value)
    text = "%.15g" % value
    return text if any(c in text for c in ".en") else text + ".0"


def format_scalar(value):
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, bool):
        return "true" if value else "false"
    return format_number(value)


def _is_scalar(value):
    return not isinstance(value, (dict, list))


def _inline_list(items, max_array):
    shown = items if not max_array or len(items) <= max_array else items[:max_array]
    text = ", ".join(format_scalar(v) for v in shown)
    if len(shown) < len(items):
        text += ", ... (%d values)" % len(items)
    return "[%s]" % text


def yaml_lines(plain, max_array=0, paint=lambda text, style: text, indent=""):
    """Lines of YAML block style for plain data; lists of scalars stay on one
    line and are cut after `max_array` values (0: never)."""
    lines = []
    if isinstance(plain, dict):
        for key, value in plain.items():
            head = indent + paint(str(key), "cyan") + ":"
            if _is_scalar(value):
                lines.append("%s %s" % (head, format_scalar(value)))
            elif isinstance(value, list) and all(_is_scalar(v) for v in value):
                lines.append("%s %s" % (head, _inline_list(value, max_array)))
            elif isinstance(value, dict) and not value:
                lines.append(head + " {}")
            else:
                lines.append(head)
                lines.extend(yaml_lines(value, max_array, paint, indent + "  "))
    elif isinstance(plain, list):
        if all(_is_scalar(v) for v in plain):
            return [indent + _inline_list(plain, max_array)]
        for item in plain:
            sub = yaml_lines(item, max_array, paint, indent + "  ")
            if sub:
                sub[0] = indent + "- " + sub[0][len(indent) + 2 :]
            else:
                sub = [indent + "- {}"]
            lines.extend(sub)
    else:
        lines.append(indent + format_scalar(plain))
    return lines


def _json_default(value):
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if np is not None:
        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, np.generic):
            return value.item()
    if isinstance(value, (bytes, bytearray)):
        return value.decode("utf-8", "replace")
    if isinstance(value, (set, tuple)):
        return list(value)
    raise TypeError("%s is not JSON serialisable" % type(value).__name__)


def to_json(data, compact=False):
    if compact:
        return json.dumps(data, default=_json_default, ensure_ascii=False, separators=(",", ":"))
    return json.dumps(data, default=_json_default, ensure_ascii=False, indent=2)


def human_rate(rate):
    if not rate:
        return "-"
    if rate >= 100:
        return "%.0f Hz" % rate
    if rate >= 1:
        return "%.1f Hz" % rate
    return "%.2f Hz" % rate


def human_bytes(n, per_second=False):
    suffix = "/s" if per_second else ""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("KB", 1e3)):
        if n >= scale:
            return "%.2f %s%s" % (n / scale, unit, suffix)
    return "%d B%s" % (n, suffix) if float(n).is_integer() else "%.1f B%s" % (n, suffix)


def human_duration(seconds):
    seconds = int(seconds)
    days, rest = divmod(seconds, 86400)
    hours, rest = divmod(rest, 3600)
    minutes, secs = divmod(rest, 60)
    if days:
        return "%dd %dh %dm" % (days, hours, minutes)
    if hours:
        return "%dh %dm %ds" % (hours, minutes, secs)
    if minutes:
        return "%dm %ds" % (minutes, secs)
    return "%ds" % secs
