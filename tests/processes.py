"""Waiting on a command a test started, always with a deadline: a test that waits fails
when the wait runs out, it never hangs."""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable

STOP_S = 30.0  # a killed process and its pipes: gone well within this


def poll_until(condition: Callable[[], bool], run: subprocess.Popen, seconds: float,
               what: str) -> None:
    """Check ``condition()`` every 50 ms until it holds; AssertionError naming ``what`` if
    ``run`` ends first (with the end of its stderr, when piped) or ``seconds`` pass (the
    caller's `stop` ends the process)."""
    deadline = time.monotonic() + seconds
    while not condition():
        if run.poll() is not None:
            stderr = run.communicate(timeout=STOP_S)[1] if run.stderr else ""
            raise AssertionError(f"the command ended (exit {run.returncode}) before {what}:\n"
                                 f"{(stderr or '')[-2000:]}")
        if time.monotonic() > deadline:
            raise AssertionError(f"no {what} within {seconds} s")
        time.sleep(0.05)


def first_line(run: subprocess.Popen, seconds: float) -> str:
    """The next line of ``run``'s stdout (text mode, piped); AssertionError if none comes in
    ``seconds``. The read happens on a helper thread, so the deadline holds while the line
    is awaited."""
    lines: list[str] = []
    assert run.stdout is not None
    reader = threading.Thread(target=lambda: lines.append(run.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout=seconds)
    if reader.is_alive() or not lines or not lines[0]:
        raise AssertionError(f"no line on stdout within {seconds} s")
    return lines[0]


def stop(run: subprocess.Popen) -> None:
    """Kill ``run`` if it is still going and wait (at most `STOP_S`) for it to end: for a
    test's ``finally``, so a failed test leaves no process behind."""
    if run.poll() is None:
        run.kill()
        run.wait(timeout=STOP_S)
