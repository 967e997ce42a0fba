"""Checkpoint files: where the shipped ones are, and whether a file is the one its
metadata describes.

The shipped CNN and tracker weights (``data/checkpoints/``) and the labelled-arm dataset
records (``data/annotations/``) travel inside the package, found through
`importlib.resources`, so an installed wheel has them as an editable checkout does. Each
checkpoint's metadata (the ``.json`` beside the ``.pt``) records the SHA-256 of its
weights, and loading checks it: flipped or truncated bytes are an error naming the file,
not a network that quietly outputs nonsense.
"""

from __future__ import annotations

import hashlib
import warnings
from importlib import resources
from pathlib import Path
from typing import Any

__all__ = ["SHIPPED_ANNOTATIONS", "SHIPPED_CHECKPOINTS", "CheckpointError", "file_sha256",
           "verify_checkpoint"]

_DATA = Path(str(resources.files("imimic_gym") / "data"))
SHIPPED_CHECKPOINTS = _DATA / "checkpoints"
SHIPPED_ANNOTATIONS = _DATA / "annotations"


class CheckpointError(ValueError):
    """A checkpoint file that cannot be used: corrupt, truncated, altered, or for another
    architecture. The message names the file."""


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of the file at ``path``, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def verify_checkpoint(path: str | Path, metadata: dict[str, Any]) -> None:
    """Check the weights at ``path`` against the ``sha256`` in their ``metadata``.

    Raises:
        CheckpointError: the file's SHA-256 differs from the recorded one.
    Warns (UserWarning) when the metadata records none (a checkpoint saved before
    checkpoints recorded it): it is loaded unverified.
    """
    expected = metadata.get("sha256")
    if expected is None:
        warnings.warn(f"checkpoint {path}: its metadata records no sha256, so it is loaded "
                      "unverified", UserWarning, stacklevel=2)
        return
    actual = file_sha256(path)
    if actual != expected:
        raise CheckpointError(f"checkpoint {path} does not match the SHA-256 its metadata "
                              f"records (corrupt or altered?): expected {expected}, got "
                              f"{actual}")
