"""Runs a command with a new pseudo-terminal as its controlling terminal, as a user's shell would,
and keeps what it writes there: to this process's stdout and to a file. Exits with its status.

    python3 pty_run.py TERMINAL_FILE COMMAND...

The wheel test (wheel_test.sh) runs `pip wheel` through it to see what a user at a terminal sees
while the package compiles (issue 32, item 6): pip hides the build's own output, and the build's
progress goes to /dev/tty (scripts/compile_progress.py).
"""

import os
import pty
import sys


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit("usage: pty_run.py TERMINAL_FILE COMMAND...")
    path, command = sys.argv[1], sys.argv[2:]
    pid, fd = pty.fork()
    if pid == 0:  # the child: session leader, the pty its stdin, stdout, stderr and /dev/tty
        try:
            os.execvp(command[0], command)
        finally:
            os._exit(127)
    with open(path, "wb") as out:
        while True:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # EIO: the child and everything it started closed the terminal
                break
            if not chunk:
                break
            out.write(chunk)
            sys.stdout.buffer.write(chunk)
            sys.stdout.flush()
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    sys.exit(os.waitstatus_to_exitcode(status))


if __name__ == "__main__":
    main()
