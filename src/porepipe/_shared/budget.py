"""The scene's memory budget (``resources.memory_budget_mb``): whether a volume fits, and the one error when a chunk
does not.

A stage holds a volume in memory when it fits the budget (or when no budget is set); otherwise it works through the
volume in chunks (:mod:`porepipe._shared.chunked`). A budget that cannot hold even the smallest chunk a stage needs
is refused with one line naming the budget and the chunk.
"""

from __future__ import annotations

import math
import os

from pydantic import BaseModel, ConfigDict, Field

from porepipe._shared.errors import PorepipeError

#: the scene key of the budget, as the messages name it
BUDGET_KEY = "resources.memory_budget_mb"
_MB = 1_000_000


class Resources(BaseModel):
    """Scene section ``resources``: what one stage process may use on this machine."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    memory_budget_mb: int | None = Field(
        None,
        ge=1,
        strict=True,
        description="memory (MB = 10^6 bytes) a stage may hold for volume data; a volume that does not fit is "
        "processed in chunks with Dask (none: every volume is held whole where the stage needs it)",
    )


def machine_bytes() -> int:
    """Physical memory of the machine in bytes (2**62 where the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 2**62


def budget_bytes(budget_mb: int | None) -> int | None:
    """The budget in bytes, or None for no budget; a non-positive or non-integer budget is an error naming the key."""
    if budget_mb is None:
        return None
    if isinstance(budget_mb, bool) or not isinstance(budget_mb, int) or budget_mb < 1:
        raise PorepipeError(f"{BUDGET_KEY} = {budget_mb!r}; allowed: a whole number of MB >= 1")
    return int(budget_mb) * _MB


def fits(nbytes: int, budget_mb: int | None) -> bool:
    """Whether ``nbytes`` fit the budget (always, without a budget)."""
    limit = budget_bytes(budget_mb)
    return limit is None or int(nbytes) <= limit


def chunk_too_large(nbytes: int, budget_mb: int | None, chunk: str) -> PorepipeError:
    """The error for a budget that cannot hold the smallest ``chunk`` (a phrase: what it is, its shape)."""
    need = math.ceil(int(nbytes) / _MB)
    return PorepipeError(
        f"{BUDGET_KEY} = {budget_mb} MB is too small for one chunk: {chunk} needs {need} MB; "
        f"give at least {BUDGET_KEY}: {need}"
    )


def planes_within(budget_mb: int | None, plane_bytes: int, fixed_bytes: int, wanted: int, chunk: str) -> int:
    """How many volume planes of ``plane_bytes`` a slab loop may hold at once (at most ``wanted``).

    Parameters
    ----------
    budget_mb : int or None
        ``resources.memory_budget_mb`` (None: ``wanted``, as far as half the machine's memory holds them).
    plane_bytes : int
        Bytes one plane costs (its input, output and temporaries together).
    fixed_bytes : int
        Bytes held whatever the slab thickness (work arrays of the threads).
    wanted : int
        The thickness asked for (a stage's ``slab_planes``).
    chunk : str
        What one plane is, for the error message.

    Returns
    -------
    int
        Planes per slab, >= 1.

    Raises
    ------
    PorepipeError
        Not even one plane fits the budget, or without one the machine's memory; the message names both.
    """
    limit = budget_bytes(budget_mb)
    if limit is None:
        memory, need = machine_bytes(), int(fixed_bytes) + int(plane_bytes)
        if need > memory:
            raise PorepipeError(
                f"{chunk} needs {need / 1e9:.3g} GB, more than this machine's {memory / 1e9:.3g} GB; use a coarser "
                "resolution"
            )
        return max(1, min(int(wanted), (memory // 2 - int(fixed_bytes)) // max(1, int(plane_bytes))))
    planes = (limit - int(fixed_bytes)) // max(1, int(plane_bytes))
    if planes < 1:
        raise chunk_too_large(int(fixed_bytes) + int(plane_bytes), budget_mb, chunk)
    return int(min(wanted, planes))
