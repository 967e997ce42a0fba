"""What every `imimic` subcommand shares: the one-line user error, argparse types,
the estimator choices and JSON output."""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from pathlib import Path

from imimic_gym.atomic import write_json


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


def finite(text: str) -> float:
    """An argparse type: a finite number (no nan or inf)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return value


def unit_interval(text: str) -> float:
    """An argparse type: a number in [0, 1] (a confidence or a fraction)."""
    value = finite(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a number from 0 to 1, got {text}")
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
        write_json(path, data)
        print(f"wrote {path}")


def check_writable(command: str, flag: str, path: str | None, folder: bool = False,
                   program: str | None = None) -> None:
    """Refuse, before any work, an output ``path`` (given as ``flag``; a folder if
    ``folder``, else a file) that cannot be written: a file where a folder is wanted or
    the reverse, a file on the way to it, or a folder this user may not write in. Folders
    on the way that do not exist yet are fine (they are made). Nothing for no path. The
    message starts with ``program`` (default: "imimic ``command``")."""
    if not path:
        return
    lead = program or f"imimic {command}"
    target = Path(path)
    wanted = "folder" if folder else "file"
    if target.exists() and target.is_dir() != folder:
        raise CommandError(f"{lead}: {flag} {path} is a "
                           f"{'file' if folder else 'folder'}; expected a {wanted} to write")
    nearest = next(p for p in (target, *target.parents) if p.exists())
    if not nearest.is_dir() and nearest != target:
        raise CommandError(f"{lead}: {flag} {path}: {nearest} is a file, not a folder")
    if not _can_write(nearest):
        raise CommandError(f"{lead}: {flag} {path}: {nearest} is not writable")


def _can_write(existing: Path) -> bool:
    """Whether this process can write the file ``existing`` or make a file in the folder
    ``existing``, found by trying (an empty file made and removed): permissions alone do
    not tell, as root's are granted on a read-only or virtual file system."""
    if not os.access(existing, os.W_OK):
        return False
    try:
        if existing.is_dir():
            with tempfile.NamedTemporaryFile(dir=existing, prefix=".imimic-write-check-"):
                pass
        else:
            with existing.open("ab"):
                pass
    except OSError:
        return False
    return True


def print_table(rows: dict[str, object]) -> None:
    width = max(len(k) for k in rows)
    for key, value in rows.items():
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        print(f"  {key:<{width}}  {shown}")


def add_clip_seeds(parser: argparse.ArgumentParser, flag: str = "") -> None:
    """--episodes, --first-seed, --frames: which clips of each scenario (``flag``: the
    option they go with, named in their help)."""
    lead = f"{flag}: " if flag else ""
    parser.add_argument("--episodes", type=at_least(1), default=3,
                        help=f"{lead}clips per scenario (default: %(default)s)")
    parser.add_argument("--first-seed", type=at_least(0), default=1000,
                        help=f"{lead}first clip seed (default: %(default)s, the first "
                             "held-out one)")
    parser.add_argument("--frames", type=at_least(2), default=None,
                        help=f"{lead}clip length in frames (default: the scenario's)")


def add_backend(parser: argparse.ArgumentParser, task: str) -> None:
    """--backend and --address: where the work runs (`backends.fan_out`); ``task`` says
    what one Ray task does."""
    from imimic_gym.backends import BACKENDS

    parser.add_argument("--backend", default="local", choices=BACKENDS,
                        help=f"local: this process (default); ray: one Ray task per {task}, "
                             "on a local Ray or the cluster at --address (pip install "
                             "'.[ray]' in a clone)")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="--backend ray: a cluster ('auto', 'ray://host:10001', "
                             "'host:6379'); default: the Ray that `ray start` runs on this "
                             "machine, else a new local one on its CPUs")


def check_backend(args: argparse.Namespace, command: str) -> None:
    if args.address and args.backend != "ray":
        raise CommandError(f"imimic {command}: --address is the Ray cluster of --backend ray")


def add_checkpoint(parser: argparse.ArgumentParser) -> None:
    """--checkpoint: the CNN's weights (a `train_cnn.py` output)."""
    parser.add_argument("--checkpoint", default=None, metavar="PATH",
                        help="the CNN's weights (--estimator cnn): a .pt that training/"
                             "train_cnn.py wrote, with its .json beside it (default: the "
                             "shipped one for the number of links followed)")


def checkpoint_params(command: str, estimators: list[str | None],
                      checkpoint: str | None) -> dict[str, str]:
    """``{"checkpoint": path}`` for the estimator parameters, {} without one. Before any
    work, refuses a checkpoint for an estimator that takes none (None: the command's
    default estimator) and a file that cannot be loaded (missing, corrupt, another
    network), each in one line (`CommandError`)."""
    if checkpoint is None:
        return {}
    from imimic_gym.estimators.registry import ESTIMATORS, get_estimator

    takers = [name for name, entry in ESTIMATORS.items() if "checkpoint" in entry.params]
    for name in estimators:
        if name is None or "checkpoint" not in get_estimator(name).params:
            which = "the default estimator" if name is None else name
            raise CommandError(f"imimic {command}: --checkpoint is the weights of "
                               f"--estimator {' or '.join(takers)}; {which} takes none")
    from imimic_gym.checkpoints import CheckpointError
    from imimic_gym.estimators.cnn.estimator import load_model

    try:
        load_model(checkpoint)
    except (OSError, CheckpointError) as error:
        raise CommandError(f"imimic {command}: --checkpoint: {error}") from error
    return {"checkpoint": checkpoint}
