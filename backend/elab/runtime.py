"""Process-wide settings of E-Lab's long-running processes (the web server, the engines).

:func:`return_memory` keeps a server's resident memory where it started after big
requests. glibc serves large allocations from its heap once a freed block has raised its
*dynamic* mmap threshold (up to 32 MiB), and a heap fragmented by a 16 MiB upload, a
streamed download and a burst of requests running at once is not given back: the web
process grew from 234 to 400 MiB over three such rounds and stayed there. With the
threshold fixed at 1 MiB, every buffer that large is its own mapping, returned when freed
(241 MiB after the same rounds; docs/benchmarks.md). Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

log = logging.getLogger(__name__)

_M_MMAP_THRESHOLD = -3  # glibc's mallopt parameters (malloc.h)
_M_ARENA_MAX = -8
MMAP_THRESHOLD = 1 << 20  # bytes: allocations this large are mappings of their own
ARENA_MAX = 2  # malloc arenas: threads share two instead of one each (8 per core)


def return_memory() -> bool:
    """Fix glibc's mmap threshold and arena count for this process; ``False`` where the
    C library is not glibc (nothing changed)."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        mallopt = libc.mallopt if libc is not None else None
    except (OSError, AttributeError):
        mallopt = None
    if mallopt is None:
        return False
    ok = bool(
        mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1 and mallopt(_M_ARENA_MAX, ARENA_MAX) == 1
    )
    if not ok:
        log.warning("mallopt refused the memory settings; big requests may keep memory")
    return ok
