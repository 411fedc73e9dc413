"""The stepper signals' names and units, read from the signal table in plugin/README.md.

That table is generated from the C++ signal table (src/core/signals.cc) by
`mjstepper tables --write plugin/README.md`, and a test (Config.ReadmeTablesAreTheTables) fails
when they differ, so this is the one table, not a copy.
"""
import os
import re

_README = os.path.join(os.path.dirname(__file__), "..", "..", "..", "plugin", "README.md")


def signal_table(readme=_README):
    """[(name, unit, meaning)] in sensordata order."""
    with open(readme, encoding="utf-8") as f:
        text = f.read()
    block = text[text.index("<!-- BEGIN signals -->"):text.index("<!-- END signals -->")]
    rows = []
    for line in block.splitlines():
        m = re.match(r"\| (\d+) \| `([a-z_]+)` \| ([^|]+) \| (.*) \|$", line)
        if m:
            rows.append((m.group(2), m.group(3).strip(), m.group(4).strip()))
    return rows


def signal_index(name):
    """Offset of signal `name` in a stepper sensor's data."""
    return [row[0] for row in signal_table()].index(name)
