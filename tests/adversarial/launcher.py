"""Start a command and report its own peak memory: ``launcher.py FD COMMAND...``.

Linux carries a process's resident-memory high-water mark across ``exec``, so a command forked
straight from a large process (a pytest worker) would be charged that process's memory. The
harness starts this small launcher instead; it forks and execs the command, waits for it, and
writes ``"<wait status> <peak RSS in KiB>"`` to the file descriptor ``FD`` before exiting with
the command's exit status.
"""

from __future__ import annotations

import os
import sys


def main() -> None:
    report, command = int(sys.argv[1]), sys.argv[2:]
    child = os.fork()
    if child == 0:
        os.close(report)
        try:
            os.execv(command[0], command)
        finally:
            os._exit(127)
    _, status, usage = os.wait4(child, 0)
    os.write(report, f"{status} {usage.ru_maxrss}".encode())
    os.close(report)
    code = os.waitstatus_to_exitcode(status)
    sys.exit(code if code >= 0 else 128 - code)


if __name__ == "__main__":
    main()
