"""Files written whole or not at all: the package's one way to write a file that others read
(the clip cache, pose labels, datasets, checkpoints, the JSON the commands write).

The bytes go to a temporary file in the target's folder (so the rename never crosses file
systems), are flushed to disk, and the file is renamed over the target: a reader, another
process or a later run sees the old file or the new one, never half of one, and a write
stopped part-way (Ctrl-C, a full disk, a crash) leaves the old file as it was.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_write", "write_bytes", "write_json", "write_text"]

# What `open(path, "w")` asks for: the user's umask then decides, as for any file they make.
NEW_FILE_MODE = 0o666


@contextmanager
def atomic_write(path: str | Path) -> Iterator[IO[bytes]]:
    """A binary file to write ``path``'s new contents into; on leaving the block without
    an exception it replaces ``path`` (folders made as needed), with the permissions any
    new file of the user gets (0o666 less the umask). On an exception the temporary file
    is removed and ``path`` is untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary, descriptor = _create_temporary(path)
    try:
        with os.fdopen(descriptor, "wb") as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    _sync_folder(path.parent)


def write_bytes(path: str | Path, data: bytes) -> None:
    """``data`` as the whole of ``path`` (`atomic_write`)."""
    with atomic_write(path) as stream:
        stream.write(data)


def write_text(path: str | Path, text: str) -> None:
    """``text`` as UTF-8, the whole of ``path`` (`atomic_write`)."""
    write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, data: Any, indent: int | None = 2) -> None:
    """``data`` as JSON (``indent``, then a newline), the whole of ``path``
    (`atomic_write`)."""
    write_text(path, json.dumps(data, indent=indent) + "\n")


def _create_temporary(path: Path) -> tuple[Path, int]:
    """A new file beside ``path`` (hidden, named after it), open for writing. Created with
    ``os.open`` and `NEW_FILE_MODE` rather than `tempfile.mkstemp`, whose files are 0600
    whatever the umask: a cache folder shared between users must stay readable to them."""
    while True:
        temporary = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
        try:
            return temporary, os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL,
                                      NEW_FILE_MODE)
        except FileExistsError:
            continue


def _sync_folder(folder: Path) -> None:
    """Flush the folder's entry for the renamed file to disk where the system allows it.
    The file itself is already whole on disk, so a folder that cannot be opened (Windows)
    or synced (some network file systems refuse, EINVAL) only loses that last step."""
    if not hasattr(os, "O_DIRECTORY"):
        return
    with suppress(OSError):
        descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
