"""Independent references for the warp tests: brute force over DP lattice paths."""

from __future__ import annotations

import numpy as np


def all_paths(n0: int, n1: int, steps: np.ndarray) -> list[list[tuple[int, int]]]:
    """Every monotone node path from (0, 0) to (n0, n1) with steps in the neighbourhood."""
    out = []

    def walk(i, j, path):
        if (i, j) == (n0, n1):
            out.append(list(path))
            return
        for a, b in steps:
            if i + a <= n0 and j + b <= n1:
                path.append((i + a, j + b))
                walk(i + a, j + b, path)
                path.pop()

    walk(0, 0, [(0, 0)])
    return out
