"""Writers stopped inside their commit windows: a Python child with lutbake.io.fileset's test hook injected
stops itself (SIGSTOP) before a set's journal and before each rename, so a test can kill it, or signal it,
exactly there (tests/io/test_fileset.py, tests/cli/test_hostile_files.py)."""

import os
import signal
import subprocess
import sys
import time

import pytest

# A child that stops itself (SIGSTOP) before a set's journal and before each rename: lutbake.io.fileset's test
# hook, injected in the child before it runs ``code`` (its arguments in sys.argv[1:]).
_STOPPING = (
    "import os, signal, sys; import lutbake.io.fileset as fileset; "
    "fileset.commit_step_hook = lambda: os.kill(os.getpid(), signal.SIGSTOP); "
)


def stopping(code: str) -> list:
    """The command line of a Python child that runs ``code`` with the stop hook set."""
    return [sys.executable, "-c", _STOPPING + code]


def stopping_cli(*args: str) -> list:
    """`lutbake ARGS` in a child with the stop hook set."""
    return [*stopping("from lutbake.cli import main; main(sys.argv[1:])"), *args]


def wait_stopped(proc: subprocess.Popen, timeout: float = 300) -> None:
    """Wait until ``proc`` stands stopped at its next stop point; fail if it exits first or never stops."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        pid, status = os.waitpid(proc.pid, os.WNOHANG | os.WUNTRACED)
        if pid and os.WIFSTOPPED(status):
            return
        assert pid == 0, f"writer exited before the commit window: {proc.stderr.read() if proc.stderr else ''}"
        time.sleep(0.02)
    proc.kill()
    pytest.fail("writer never reached the commit window")


def kill_at(proc: subprocess.Popen, stop: int) -> None:
    """Let the writer pass ``stop`` stop points, then SIGKILL it inside the next window."""
    for _ in range(stop):
        wait_stopped(proc)
        os.kill(proc.pid, signal.SIGCONT)
    wait_stopped(proc)
    os.kill(proc.pid, signal.SIGKILL)
    os.waitpid(proc.pid, 0)
