"""A study's committed page, figures and video are what its script writes (issue 32, item 2).

    study_check.py SOURCE_DIR SCRIPT [SCRIPT...]

Runs each study script (a path under SOURCE_DIR, e.g. src/tools/python/study_arm.py) with the
build's venv, in a scratch copy of the tracked tree, and fails naming every tracked file the run
changed: a page whose numbers, a figure whose pixels or a video whose frames no longer match their
script, or a wall time or a machine's path written into a tracked file. The studies are
deterministic (fixed seeds, fixed steps, one thread per run where the order would matter), so a
committed file changes only when its script's answer does.
"""
import os
import shutil
import subprocess
import sys
import time

from scratch_tree import changed_files, exit_with, scratch_copy

SOURCE = os.path.abspath(sys.argv[1])


def main():
    root, tracked = scratch_copy(SOURCE)
    failures = []
    try:
        for script in sys.argv[2:]:
            start = time.monotonic()
            proc = subprocess.run([os.path.join(root, ".venv", "bin", "python"),
                                   os.path.join(root, script)], cwd=root, capture_output=True,
                                  text=True, timeout=1800)
            print(f"{script}: exit {proc.returncode} in {time.monotonic() - start:.0f} s",
                  flush=True)
            if proc.returncode != 0:
                failures.append(f"{script}: exit {proc.returncode}\n{proc.stderr[-3000:]}")
        for path in changed_files(SOURCE, root, tracked):
            failures.append(f"{path}: not what its script writes (compare {root}/{path})")
    finally:
        if not failures:
            shutil.rmtree(root, ignore_errors=True)
    exit_with(failures)


if __name__ == "__main__":
    main()
