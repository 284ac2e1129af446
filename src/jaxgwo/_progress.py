"""A small progress line on stderr for long host-side loops (no dependency).

Progress is reported between compiled calls (one Monte-Carlo chunk, one comparison run, one
identification stage), never from inside a jitted scan: a host callback there would
synchronise every iteration.  The line is rewritten in place with ``\\r``::

    montecarlo [############..................] 400/1000 seeds  41.2 seeds/s  ETA 0:15

It is shown only when the stream is a terminal and ``quiet`` is false, so logs, pipes and
CI output stay clean.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "format_duration"]


def format_duration(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``) for an ETA; ``?`` when unknown."""
    if not (seconds >= 0.0) or seconds == float("inf"):
        return "?"
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """Progress of ``total`` units of work (seeds, runs, stages) on ``stream``.

    ``update(done)`` sets the count, ``advance(n)`` adds to it; ``note`` is shown after the
    rate (for example the run just finished).  The rate and ETA count from the first
    update, so the first unit (usually compilation) is not spread over the others:
    until a second update the ETA reads ``?``.  Use as a context manager, or call
    :meth:`close` to end the line.  ``enabled`` defaults to ``stream.isatty() and not
    quiet``; a disabled progress writes nothing.  ``eta=False`` drops the rate and ETA,
    for units of very different lengths (identification stages).
    """

    def __init__(self, total: int, label: str = "", unit: str = "", *,
                 stream: TextIO | None = None, quiet: bool = False,
                 enabled: bool | None = None, width: int = 30, eta: bool = True,
                 clock=time.perf_counter):
        self.total = max(0, int(total))
        self.label = label
        self.unit = unit
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty()) and not quiet
        self.enabled = enabled
        self.width = width
        self.eta = eta
        self.done = 0
        self._clock = clock
        self._t0 = clock()
        self._first: tuple[float, int] | None = None  # (time, count) of the first update
        self._last_len = 0
        self._closed = False

    def __enter__(self) -> "Progress":
        self._render("")
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def advance(self, n: int = 1, note: str = "") -> None:
        self.update(self.done + n, note)

    def update(self, done: int, note: str = "") -> None:
        self.done = min(int(done), self.total) if self.total else int(done)
        now = self._clock()
        if self._first is None:
            self._first = (now, self.done)
        self._render(note, now)

    def line(self, note: str = "", now: float | None = None) -> str:
        """The text of the progress line (without ``\\r``)."""
        now = self._clock() if now is None else now
        frac = self.done / self.total if self.total else 1.0
        filled = int(self.width * frac)
        bar = "#" * filled + "." * (self.width - filled)
        unit = f" {self.unit}" if self.unit else ""
        parts = [f"{self.label} [{bar}] {self.done}/{self.total}{unit}".lstrip()]
        rate = None
        if self.eta and self._first is not None:
            t1, n1 = self._first
            if self.done > n1 and now > t1:
                rate = (self.done - n1) / (now - t1)
        if rate:
            per = f"{self.unit}/s" if self.unit else "/s"
            parts.append(f"{rate:.3g} {per}")
            parts.append(f"ETA {format_duration((self.total - self.done) / rate)}")
        elif self.eta and self.done < self.total:
            parts.append("ETA ?")
        parts.append(f"elapsed {format_duration(now - self._t0)}")
        if note:
            parts.append(note)
        return "  ".join(parts)

    def _render(self, note: str, now: float | None = None) -> None:
        if not self.enabled or self._closed:
            return
        text = self.line(note, now)
        pad = " " * max(0, self._last_len - len(text))  # wipe the tail of a longer line
        self._last_len = len(text)
        self.stream.write("\r" + text + pad)
        self.stream.flush()

    def close(self) -> None:
        """End the line (a newline), once."""
        if self.enabled and not self._closed and self._last_len:
            self.stream.write("\n")
            self.stream.flush()
        self._closed = True
