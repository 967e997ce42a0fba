"""What every `imimic` subcommand shares: the one-line user error, argparse types,
the estimator choices and JSON output."""

from __future__ import annotations

import argparse
import json
from pathlib import Path


class CommandError(SystemExit):
    """A user's mistake on the command line: `main` prints it in one line on stderr and
    the command exits with code 2 (a traceback is for bugs)."""

    def __init__(self, message: str) -> None:
        super().__init__(2)
        self.message = message

    def __str__(self) -> str:
        return self.message


def at_least(low: int):
    """An argparse type: a whole number >= ``low`` (argparse says so in one line, exit 2)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"expected a whole number of at least {low}, "
                                             f"got {value}")
        return value

    parse.__name__ = f"integer >= {low}"
    return parse


def positive(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number above 0, got {text}")
    return value


def estimator_names(video_only: bool = False) -> tuple[str, ...]:
    """The registered estimators (`estimators.registry`) for ``--estimator`` choices;
    ``video_only`` leaves out those that read the truth rather than the video."""
    from imimic_gym.estimators.registry import ESTIMATORS

    return tuple(name for name, entry in ESTIMATORS.items()
                 if not (video_only and entry.needs_truth))


def save_json(path: str | None, data: object) -> None:
    """Write ``data`` as JSON to ``path`` (folders made as needed); nothing if no path."""
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(data, indent=2) + "\n")
        print(f"wrote {path}")


def print_table(rows: dict[str, object]) -> None:
    width = max(len(k) for k in rows)
    for key, value in rows.items():
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        print(f"  {key:<{width}}  {shown}")
