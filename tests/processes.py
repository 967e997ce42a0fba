"""Waiting on a command a test started, always with a deadline: a test that waits fails
when the wait runs out, it never hangs."""

from __future__ import annotations

import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

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


# For a Python command a test starts: faulthandler on, so that `wait_for_exit` can have it
# print every thread's stack when it hangs.
DUMPS_STACKS = {"PYTHONFAULTHANDLER": "1"}


def wait_for_exit(run: subprocess.Popen, seconds: float) -> tuple[str, str]:
    """``run.communicate()`` within ``seconds``. If it has not ended by then, SIGABRT
    makes a Python command started with `DUMPS_STACKS` in its environment print every
    thread's stack, and AssertionError carries that (the end of stderr), so a hang that
    CI meets once says where it hung."""
    try:
        return run.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        run.send_signal(signal.SIGABRT)
        try:
            _, stderr = run.communicate(timeout=STOP_S)
        except subprocess.TimeoutExpired:
            run.kill()
            _, stderr = run.communicate(timeout=STOP_S)
        raise AssertionError(f"the command did not end within {seconds} s; its stacks:\n"
                             f"{(stderr or '')[-8000:]}") from None


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


def _listening(port: int) -> bool:
    """True once a socket listens on local TCP ``port`` (Linux's /proc/net/tcp; no probe
    connection, which a one-client server would take for its client)."""
    rows = Path("/proc/net/tcp").read_text().splitlines()[1:]
    return any(row.split()[1].endswith(f":{port:04X}") and row.split()[3] == "0A"
               for row in rows)


def stream_live(path: Path, seconds: float = 10.0) -> tuple[subprocess.Popen, str]:
    """``path`` played at its own frame rate by ffmpeg (``-re``, not re-encoded) as an
    MPEG-TS stream to the first client of a local TCP port, as an IP camera sends one:
    the player (for the caller's `stop`) and the stream's URL, once it listens (within
    ``seconds``, else AssertionError)."""
    import imageio_ffmpeg

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    player = subprocess.Popen([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "quiet", "-re",
                               "-i", str(path), "-c", "copy", "-f", "mpegts",
                               f"tcp://127.0.0.1:{port}?listen=1"])
    deadline = time.monotonic() + seconds
    while not _listening(port):
        if player.poll() is not None or time.monotonic() > deadline:
            stop(player)
            raise AssertionError(f"ffmpeg did not listen on port {port} within {seconds} s")
        time.sleep(0.05)
    return player, f"tcp://127.0.0.1:{port}"
