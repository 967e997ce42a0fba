"""Every wait a test makes on a process or a thread has a deadline (issue 40): a test that
waits fails when the wait runs out, it never hangs CI."""

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
SUBPROCESS_WAITS = {"run", "call", "check_call", "check_output"}
# Popen.communicate/wait, Thread.join, Queue.get, Event.wait: all wait forever without one.
METHOD_WAITS = {"communicate", "wait", "join", "get"}


def waits_without_deadline(source: str) -> list[int]:
    """The lines of ``source`` with a call that can wait forever: a `subprocess` call
    without ``timeout=``, or a ``communicate``/``wait``/``join``/``get`` with no argument
    at all (``str.join`` and ``dict.get`` always have one; a timeout may be positional)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        name, owner = node.func.attr, node.func.value
        timed = any(keyword.arg == "timeout" for keyword in node.keywords)
        if isinstance(owner, ast.Name) and owner.id == "subprocess":
            if name in SUBPROCESS_WAITS and not timed:
                lines.append(node.lineno)
        elif name in METHOD_WAITS and not (node.args or node.keywords):
            lines.append(node.lineno)
    return lines


def test_the_check_finds_each_kind_of_endless_wait() -> None:
    source = ("subprocess.run(['x'])\nrun.communicate()\nrun.wait()\nthread.join()\n"
              "queue.get()\nsubprocess.run(['x'], timeout=5)\nrun.communicate(timeout=5)\n"
              "run.wait(5)\nthread.join(timeout=1)\n', '.join(words)\nrow.get('key')\n")
    assert waits_without_deadline(source) == [1, 2, 3, 4, 5]


def test_no_test_waits_on_a_process_or_thread_without_a_deadline() -> None:
    endless = [f"{path.relative_to(TESTS)}:{line}" for path in sorted(TESTS.rglob("*.py"))
               for line in waits_without_deadline(path.read_text())]
    assert endless == []


def test_a_command_that_hangs_fails_the_test_with_its_stacks() -> None:
    """`processes.wait_for_exit`: a Python command that outlives its deadline is stopped
    and the failure shows where each of its threads was."""
    import subprocess
    import sys

    import pytest

    from tests.processes import DUMPS_STACKS, stop, wait_for_exit

    run = subprocess.Popen([sys.executable, "-c", "import time\ndef stuck():\n    "
                            "time.sleep(60)\nstuck()\n"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, env=DUMPS_STACKS)
    try:
        with pytest.raises(AssertionError, match="did not end within 1 s") as failure:
            wait_for_exit(run, 1)
    finally:
        stop(run)
    assert "in stuck" in str(failure.value)
    assert wait_for_exit(subprocess.Popen([sys.executable, "-c", "print('done')"],
                                          stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                          text=True), 60)[0] == "done\n"
