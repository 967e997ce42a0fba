"""Ctrl-C as the commands see it: the forms it arrives in, and a Ctrl-C before the
`imimic` command can catch anything."""

import ctypes
import os
import subprocess
import sys
from pathlib import Path

import pytest

import imimic_gym
from imimic_gym.interrupts import CTRL_C, is_ctrl_c

REPO = Path(imimic_gym.__file__).resolve().parents[1]


def ctypes_error(raised: BaseException) -> BaseException:
    """What ctypes raises when converting a call's argument raises ``raised`` (PyOpenGL's
    conversions run Python code; a Ctrl-C there arrives this way)."""

    class Converted:
        @classmethod
        def from_param(cls, value):
            raise raised

    absolute = ctypes.CDLL(None).abs
    absolute.argtypes = [Converted]
    try:
        absolute(1)
    except BaseException as error:
        return error
    raise AssertionError("the call did not fail")


def test_ctrl_c_in_a_ctypes_calls_arguments_counts_as_ctrl_c() -> None:
    interrupted = ctypes_error(KeyboardInterrupt())
    assert isinstance(interrupted, ctypes.ArgumentError) and isinstance(interrupted, CTRL_C)
    assert is_ctrl_c(interrupted)
    assert not is_ctrl_c(ctypes_error(TypeError("not an int")))


def test_ctrl_c_stopping_a_compiled_modules_initialisation_counts_as_ctrl_c() -> None:
    """A pybind11 module whose initialisation Ctrl-C stops raises ImportError
    ("initialization failed") from the KeyboardInterrupt; any other ImportError is not."""
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as interrupt:
            raise ImportError("initialization failed") from interrupt
    except ImportError as error:
        stopped = error
    assert isinstance(stopped, CTRL_C) and is_ctrl_c(stopped)
    assert not is_ctrl_c(ImportError("No module named 'ray'"))


# Run at interpreter start (sitecustomize): send this process SIGINT when the command's
# imports reach the module named by IMIMIC_TEST_INTERRUPT_AT, i.e. inside those imports.
SITECUSTOMIZE = '''
import os, signal, sys

class InterruptAt:
    def find_spec(self, name, path=None, target=None):
        if name == os.environ["IMIMIC_TEST_INTERRUPT_AT"]:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, InterruptAt())
'''


@pytest.mark.parametrize("launch", ["module", "script"])
@pytest.mark.parametrize("module", ["gymnasium", "mujoco", "imimic_gym.sweep"])
def test_ctrl_c_while_the_command_starts_is_one_line_and_exit_130(tmp_path, launch,
                                                                  module) -> None:
    """A Ctrl-C during the imports of `python -m imimic_gym.cli` or of the `imimic`
    console script (the package's, then a command's): no traceback."""
    (tmp_path / "sitecustomize.py").write_text(SITECUSTOMIZE)
    script = tmp_path / "imimic"  # as pip writes the console script
    script.write_text("import sys\nfrom imimic_gym.cli import main\nsys.exit(main())\n")
    start = ([sys.executable, "-m", "imimic_gym.cli"] if launch == "module"
             else [sys.executable, str(script)])
    done = subprocess.run([*start, "eval", "--backend", "ray", "--frames", "2"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{REPO}",
                               "IMIMIC_TEST_INTERRUPT_AT": module,
                               "IMIMIC_CACHE_DIR": str(tmp_path / "cache")})
    assert done.returncode == 130, done.stderr[-3000:]
    assert done.stderr.strip().splitlines()[-1].endswith("stopped by Ctrl-C"), done.stderr
    assert "Traceback" not in done.stderr, done.stderr[-3000:]


def test_unstoppable_ignores_ctrl_c_inside_and_restores_it() -> None:
    import signal
    import time

    from imimic_gym.interrupts import unstoppable

    # Python's own handler, whatever the runner started with (a shell's background job
    # starts with Ctrl-C ignored).
    started_with = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        finished = False
        with unstoppable():
            os.kill(os.getpid(), signal.SIGINT)  # handled by this (main) thread at once
            time.sleep(0.05)
            finished = True
        assert finished and signal.getsignal(signal.SIGINT) is signal.default_int_handler
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # interrupted by the KeyboardInterrupt long before
    finally:
        signal.signal(signal.SIGINT, started_with)


def test_ctrl_c_held_raises_it_as_the_block_ends_and_restores_the_handler() -> None:
    """`ctrl_c_held`: the block runs to its end, then the Ctrl-C it held is raised; a block
    without one ends quietly; held across a generator's yield, the consumer's step between
    two frames is inside; where Ctrl-C is ignored it stays ignored."""
    import signal
    import time

    from imimic_gym.interrupts import ctrl_c_held

    started_with = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        finished = False
        with pytest.raises(KeyboardInterrupt):
            with ctrl_c_held():
                os.kill(os.getpid(), signal.SIGINT)  # handled by this (main) thread at once
                time.sleep(0.05)
                finished = True
        assert finished and signal.getsignal(signal.SIGINT) is signal.default_int_handler
        with ctrl_c_held():
            pass

        def frames():
            for i in range(3):
                with ctrl_c_held():
                    yield i

        handed: list[int] = []
        with pytest.raises(KeyboardInterrupt):
            for frame in frames():
                if frame == 1:
                    os.kill(os.getpid(), signal.SIGINT)  # between taking frame 1 and keeping it
                    time.sleep(0.05)
                handed.append(frame)
        assert handed == [0, 1]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a background job ignores Ctrl-C
        with ctrl_c_held():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, started_with)
