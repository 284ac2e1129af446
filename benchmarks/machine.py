"""What machine a benchmark ran on, for the header of its results file."""

from __future__ import annotations

import os
import platform


def cpu_model() -> str:
    """The CPU's model name from ``/proc/cpuinfo``, else what ``platform`` knows."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def pin_cpus(n: int) -> None:
    """Pin this process to its first ``n`` allowed cores (0: leave it alone).  Call it
    before JAX is imported: XLA sizes its thread pool from the affinity when it starts."""
    if n:
        os.sched_setaffinity(0, set(sorted(os.sched_getaffinity(0))[:n]))
