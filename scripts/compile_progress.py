#!/usr/bin/env python3
"""The Python package's build progress, on the terminal that pip hides the build from.

pip captures a build backend's output and shows it only with -v (pip's issue 6634), so
`pip install .` would show a spinner for the minutes the package compiles. The package's CMake
build (CMakeLists.txt, MJSTEPPER_PACKAGE) runs every compile through this launcher: it writes

    mjstepper: compiling 12 of 71: src/tools/cli.cc

to the controlling terminal of the install, when it has one (nothing when it has none: CI, cron,
nohup), then becomes the compiler (or ccache) with the same arguments, so the compile command and
ccache's view of it are unchanged. MJSTEPPER_BUILD_PROGRESS=0 turns it off.

    compile_progress.py COUNT_FILE SOURCE_DIR COMPILER_COMMAND...

COUNT_FILE (emptied by CMake at configure time) grows by one byte per compile started, under a
lock, so parallel compiles number themselves 1, 2, ...; the total is the number of compile edges
in the build.ninja of the folder Ninja runs the compile in.
"""

import fcntl
import os
import sys


def _total_compiles() -> int:
    try:
        with open("build.ninja", encoding="utf-8") as ninja:
            return sum(1 for line in ninja
                       if line.startswith("build ") and "_COMPILER__" in line)
    except OSError:
        return 0


def _number_this_compile(count_file: str) -> int:
    fd = os.open(count_file, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, b".")
        return os.fstat(fd).st_size
    finally:
        os.close(fd)  # releases the lock


def _report(count_file: str, source_dir: str, command: list[str]) -> None:
    if os.environ.get("MJSTEPPER_BUILD_PROGRESS", "1") == "0":
        return
    try:
        tty = open("/dev/tty", "w", encoding="utf-8")  # the install's terminal, if any
    except OSError:
        return
    with tty:
        source = command[command.index("-c") + 1] if "-c" in command else command[-1]
        if os.path.isabs(source) and source.startswith(source_dir + os.sep):
            source = os.path.relpath(source, source_dir)
        number = _number_this_compile(count_file)
        total = _total_compiles()
        of = f" of {total}" if total >= number else ""
        # "\r": a line of its own, over whatever pip's spinner left at its start.
        tty.write(f"\rmjstepper: compiling {number}{of}: {source}\n")


def main() -> None:
    if len(sys.argv) < 4:
        sys.exit("usage: compile_progress.py COUNT_FILE SOURCE_DIR COMPILER_COMMAND...")
    count_file, source_dir, command = sys.argv[1], sys.argv[2], sys.argv[3:]
    try:
        _report(count_file, source_dir, command)
    except OSError:
        pass  # progress is a courtesy: never the reason a build fails
    os.execvp(command[0], command)


if __name__ == "__main__":
    main()
