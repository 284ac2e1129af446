"""Atomic output: every file jaxgwo writes goes through a temporary file in the same
directory, is flushed and fsynced, then renamed into place, so an interrupted or failed
command never leaves a half-written output behind."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from typing import IO

TEMP_SUFFIX = ".tmp"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary sibling of ``path`` for writing; on a clean exit it replaces
    ``path`` (with the usual permissions), on an exception it is deleted."""
    target = os.path.abspath(os.fspath(path))
    directory = os.path.dirname(target)
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"directory does not exist: {directory}")
    fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(target)}.", suffix=TEMP_SUFFIX,
                               dir=directory)
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8)."""
    with atomic_output(path, "wb") as fh:
        fh.write(text.encode("utf-8"))


def atomic_savefig(fig, path: str | os.PathLike, dpi: int = 110) -> None:
    """``fig.savefig`` atomically; the format follows the extension (PNG by default)."""
    fmt = (os.path.splitext(os.fspath(path))[1].lstrip(".") or "png").lower()
    with atomic_output(path, "wb") as fh:
        fig.savefig(fh, format=fmt, dpi=dpi)
