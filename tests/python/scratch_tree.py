"""A scratch copy of the tracked tree, for tests that run the docs' commands or the studies as a
user would from a clone, without touching the clone (tests/python/docs_check.py, study_check.py)."""
import filecmp
import os
import shutil
import subprocess
import sys
import tempfile


def scratch_copy(source):
    """(root, tracked): a new folder holding a copy of every tracked file of `source`, with its
    build/ and .venv/ linked in; the tracked paths, relative."""
    root = tempfile.mkdtemp(prefix="mjstepper_scratch_")
    listed = subprocess.run(["git", "-C", source, "ls-files", "-z"], check=True,
                            capture_output=True).stdout.decode().split("\0")
    tracked = [t for t in listed if t and os.path.isfile(os.path.join(source, t))]
    for path in tracked:
        os.makedirs(os.path.join(root, os.path.dirname(path)), exist_ok=True)
        shutil.copy2(os.path.join(source, path), os.path.join(root, path))
    for linked in ("build", ".venv"):
        os.symlink(os.path.join(source, linked), os.path.join(root, linked))
    return root, tracked


def changed_files(source, root, tracked):
    """The tracked files whose copy under `root` differs from the clone's, byte for byte."""
    return [t for t in tracked
            if not os.path.isfile(os.path.join(root, t))
            or not filecmp.cmp(os.path.join(source, t), os.path.join(root, t), shallow=False)]


def exit_with(failures):
    """Prints each failure to stderr and exits 1, or exits 0 when there is none."""
    for failure in failures:
        print(f"FAIL {failure}", file=sys.stderr)
    sys.exit(1 if failures else 0)
