"""Name and index look-ups shared by link, joint and frame: clear errors that name what is wrong."""

from __future__ import annotations

import numpy as np


def name_to_idx(kind: str, names: tuple[str, ...], name: str, offset: int = 0) -> int:
    try:
        return offset + names.index(name)
    except ValueError:
        raise ValueError(f"the model has no {kind} named '{name}' (its {kind}s: {list(names)})") from None


def check_idx(kind: str, count: int, index, offset: int = 0) -> int:
    if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
        raise TypeError(f"{kind}_index must be an integer, got {index!r}")
    if not offset <= int(index) < offset + count:
        raise IndexError(f"{kind}_index {int(index)} is out of range [{offset}, {offset + count})")
    return int(index)
