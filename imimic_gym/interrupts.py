"""Ctrl-C as the commands that keep their partial work see it.

A Ctrl-C that lands inside a compiled numba loop (DON's layers) does not arrive as a bare
`KeyboardInterrupt`: Python raises a `SystemError` ("returned a result with an exception
set") over it, once per compiled call it interrupts. Catch `CTRL_C` and ask `is_ctrl_c`.
"""

from __future__ import annotations

__all__ = ["CTRL_C", "is_ctrl_c"]

CTRL_C = (KeyboardInterrupt, SystemError)  # what to catch; then ask is_ctrl_c


def is_ctrl_c(error: BaseException | None) -> bool:
    """Whether ``error`` is Ctrl-C: a KeyboardInterrupt, or SystemErrors raised over one."""
    while isinstance(error, SystemError):
        error = error.__cause__
    return isinstance(error, KeyboardInterrupt)
