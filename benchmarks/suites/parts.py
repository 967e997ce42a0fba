"""Suites made of named parts: `run.py SUITE --parts A B` runs some of them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from imimic_gym.bench import machine


def run_parts(suite: str, measure: dict[str, Callable[[Any], dict[str, Any]]],
              args: Any) -> dict[str, Any]:
    """``{"machine", "quick", part: measure[part](args), ...}`` for ``args.parts`` (default:
    every part of ``measure``, in its order). Exits naming the parts on an unknown one."""
    parts = args.parts or list(measure)
    unknown = sorted(set(parts) - set(measure))
    if unknown:
        raise SystemExit(f"suite {suite} has no part {', '.join(unknown)}; "
                         f"parts: {', '.join(measure)}")
    data: dict[str, Any] = {"machine": machine(), "quick": bool(args.quick)}
    for part in parts:
        data[part] = measure[part](args)
    return data
