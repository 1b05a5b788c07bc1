"""A least-recently-used cache with a budget in bytes, for the refined skins of a face.

An animation with adaptive refinement meets a new set of split triangles almost every frame,
and each refined skin carries its own per-muscle data and stacked operators. Counting entries
does not bound that memory (a refined skin of the 20k face weighs about 40 MB, one of the
paper-size face about 5 MB); weighing them does.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np
import scipy.sparse as sp

__all__ = ["ByteBudgetCache", "HoldsArrays", "nbytes"]


def nbytes(*objects) -> int:
    """Bytes held by the numpy arrays and sparse matrices in ``objects``.

    Follows dicts, lists, tuples and the ``__dict__`` of plain objects, each object once;
    an object with an ``arrays()`` method is weighed by the arrays it lists (what it holds,
    not what it refers to); anything else (muscles, strings, trees) counts as nothing.
    """
    seen: set[int] = set()
    total = 0
    stack = list(objects)
    while stack:
        obj = stack.pop()
        if id(obj) in seen or obj is None:
            continue
        seen.add(id(obj))
        if isinstance(obj, np.ndarray):
            if isinstance(obj.base, np.ndarray):  # a view: its base counts, once
                stack.append(obj.base)
            elif obj.base is None:
                total += obj.nbytes
        elif sp.issparse(obj):
            stack += [getattr(obj, k, None) for k in ("data", "indices", "indptr", "row",
                                                      "col")]
        elif isinstance(obj, dict):
            stack += list(obj.values())
        elif isinstance(obj, (list, tuple)):
            stack += list(obj)
        elif callable(getattr(obj, "arrays", None)):
            stack += obj.arrays()
        elif hasattr(obj, "__dict__"):
            stack += list(vars(obj).values())
    return total


class HoldsArrays:
    """Weighed (:func:`nbytes`) by the arrays among its own attributes, not by the objects
    it refers to (a muscle, the hierarchy).
    """

    def arrays(self) -> list[np.ndarray]:
        """The arrays it holds."""
        return [v for v in vars(self).values() if isinstance(v, np.ndarray)]


class ByteBudgetCache:
    """Least-recently-used entries whose weights, in bytes, add up to at most ``budget``.

    Parameters
    ----------
    budget : int
        The most bytes the entries may weigh together; the newest entry is kept even when
        it alone weighs more.
    """

    def __init__(self, budget: int):
        self.budget = int(budget)
        self._entries: OrderedDict[Hashable, tuple[Any, int]] = OrderedDict()
        self._total = 0

    def __len__(self) -> int:
        return len(self._entries)

    @property
    def total(self) -> int:
        """Bytes the entries weigh now."""
        return self._total

    def get(self, key: Hashable, build: Callable[[], Any]) -> Any:
        """The entry for ``key``, made by ``build()`` (and weighed) when missing."""
        entry = self._entries.get(key)
        if entry is not None:
            self._entries.move_to_end(key)
            return entry[0]
        value = build()
        self._entries[key] = (value, 0)
        self.reweigh(key, value)
        return value

    def put(self, key: Hashable, value: Any) -> None:
        """Store ``value`` under ``key`` (replacing what was there) and weigh it."""
        old = self._entries.pop(key, None)
        if old is not None:
            self._total -= old[1]
        self._entries[key] = (value, 0)
        self.reweigh(key, value)

    def reweigh(self, key: Hashable, *objects) -> None:
        """Weigh ``key``'s entry again (``objects``: what it holds now, default the entry);
        entries that grew after they were made (lazy caches) are counted as they are.
        """
        entry = self._entries.get(key)
        if entry is None:
            return
        weight = nbytes(*(objects or (entry[0],)))
        self._total += weight - entry[1]
        self._entries[key] = (entry[0], weight)
        while self._total > self.budget and len(self._entries) > 1:
            oldest = next(iter(self._entries))
            if oldest == key:
                self._entries.move_to_end(key)
                continue
            self._total -= self._entries.pop(oldest)[1]
