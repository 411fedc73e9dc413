"""Every command block of the docs runs as written (issue 32, item 1).

    docs_check.py SOURCE_DIR

Finds every shell block in the docs (a fenced ```sh or ```bash block, or an indented line that
starts a command: `bash `, `build/`, `.venv/`), and runs each, in order, with bash -euo pipefail,
from the root of a scratch copy of the tracked tree (the build and the venv linked in), as a user
who pastes it from a fresh clone after the build would. A block fails the test when it exits
non-zero, when it holds a synopsis (`[--option]` brackets: those belong in a ```text block), or when
it changes a tracked file (the docs' commands write only into out/).

The few blocks that cannot run here are listed in NOT_RUN by their first line, each with the
reason; they are still checked with `bash -n` and every script or file they name must exist, and a
listed line that no longer appears in any doc fails the test (the list stays true).
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import time

from scratch_tree import changed_files, exit_with, scratch_copy

SOURCE = os.path.abspath(sys.argv[1])
DOCS = (["README.md", "BENCHMARKS.md", "plugin/README.md", "models/README.md",
         "renders/README.md"]
        + sorted(glob.glob("docs/**/*.md", root_dir=SOURCE, recursive=True))
        + sorted(glob.glob("models/**/README.md", root_dir=SOURCE, recursive=True))
        + sorted(glob.glob("tests/**/README.md", root_dir=SOURCE, recursive=True)))

# First line of a block → why it is not run here.
NOT_RUN = {
    "bash scripts/study.sh   # main job: the default study → renders/ (video, plots) and logs/ (CSV)":
        "the main job: minutes, and it rewrites tracked pages (the README's own measure)",
    "bash tests/fuzz/run.sh                     # config_fuzz, 45 s":
        "the fuzzers: ctest runs them (Fuzz.*)",
    "bash scripts/sanitize.sh            # extra arguments go to ctest, e.g. -R Config":
        "a second build of everything under sanitizers: minutes",
    "bash scripts/build.sh bench_render && build/bench_render":
        "a benchmark: a timing, not a check (the build builds it)",
    "bash scripts/build.sh bench_step && build/bench_step":
        "a benchmark: a timing, not a check (the build builds it)",
    "pip install \".[ray]\"        # the package with ray==2.60.0":
        "compiles the package: the wheel test (Python.Wheel…) installs it with its Ray extra",
    "mkdir -p /tmp/kbatch && cd /tmp/kbatch":
        "fetches Klipper from GitHub: this machine reaches only Debian and PyPI",
    "python3 -m venv /tmp/kvenv && /tmp/kvenv/bin/pip install numpy matplotlib":
        "fetches Klipper from GitHub: this machine reaches only Debian and PyPI",
    ".venv/bin/python src/tools/python/coupling_curves.py":
        "a fidelity study: tens of minutes",
    "bash scripts/reproduce_kim2016.sh": "regenerates a tracked page (a reproduction script)",
    "bash scripts/reproduce_tsui2009.sh": "regenerates a tracked page (a reproduction script)",
}
# The first line of the test command's own block (bash scripts/test.sh): running it here would run
# this test again.
SELF = "bash scripts/test.sh    # builds everything and runs every test (ctest: GoogleTest and Python)"

FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.S | re.M)
INDENTED = re.compile(r"(?:^|\n\n)    ((?:bash |build/|\.venv/)[^\n]*)")


def blocks():
    """(doc, line, text) of every shell block, in the docs' order."""
    found = []
    for doc in DOCS:
        with open(os.path.join(SOURCE, doc), encoding="utf-8") as f:
            text = f.read()
        for m in FENCE.finditer(text):
            if m.group(1) in ("sh", "bash", "shell", "console"):
                found.append((doc, text.count("\n", 0, m.start()) + 1, m.group(2)))
        for m in INDENTED.finditer(text):
            if not any(m.start(1) > s and m.start(1) < e
                       for s, e in (x.span() for x in FENCE.finditer(text))):
                found.append((doc, text.count("\n", 0, m.start(1)) + 1, m.group(1) + "\n"))
    return found


def main():
    failures = []
    found = blocks()
    firsts = {text.splitlines()[0] for _, _, text in found}
    for line in NOT_RUN:
        if line not in firsts:
            failures.append(f"NOT_RUN lists {line!r}, which no doc holds any more")
    root, tracked = scratch_copy(SOURCE)
    try:
        for doc, line, text in found:
            first = text.splitlines()[0]
            where = f"{doc}:{line}"
            if re.search(r"\[--?\w", text):
                failures.append(f"{where}: a synopsis ([--option]) in a shell block: {first}")
                continue
            if first == SELF:
                print(f"{where}: the test command itself (this test is one of its tests)")
                continue
            if first in NOT_RUN:
                check = subprocess.run(["bash", "-n", "-c", text], capture_output=True, text=True)
                named = re.findall(r"(?<![\w/.])(?:scripts|tests|src)/[\w./-]+\.(?:sh|py)",
                                   text)
                missing = [n for n in named if not os.path.exists(os.path.join(SOURCE, n))]
                if check.returncode != 0 or missing:
                    failures.append(f"{where}: {check.stderr.strip()} missing {missing}")
                print(f"{where}: not run ({NOT_RUN[first]}); syntax and files checked")
                continue
            start = time.monotonic()
            proc = subprocess.run(["bash", "-euo", "pipefail", "-c", text], cwd=root,
                                  capture_output=True, text=True, timeout=600)
            took = time.monotonic() - start
            print(f"{where}: exit {proc.returncode} in {took:.1f} s: {first[:80]}", flush=True)
            if proc.returncode != 0:
                failures.append(f"{where}: exit {proc.returncode}\n{text}\n{proc.stdout[-2000:]}"
                                f"{proc.stderr[-2000:]}")
        changed = changed_files(SOURCE, root, tracked)
        if changed:
            failures.append(f"the docs' commands changed tracked files: {changed}")
    finally:
        shutil.rmtree(root, ignore_errors=True)
    exit_with(failures)


if __name__ == "__main__":
    main()
