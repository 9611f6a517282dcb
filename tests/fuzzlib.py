"""Shared by the fuzz tests (scenario, study and wound inputs): random damage to a file's bytes."""

import numpy as np


def damage(rng: np.random.Generator, raw: bytes, junk: list[bytes], max_ops: int = 5, max_cut: int = 20) -> bytes:
    """``raw`` after 1 .. ``max_ops`` - 1 random edits: a cut of up to ``max_cut`` bytes, an insertion
    of one of ``junk``, or a truncation."""
    data = bytearray(raw)
    for _ in range(rng.integers(1, max_ops)):
        at = int(rng.integers(len(data) + 1))
        op = rng.integers(3)
        if op == 0:
            data[at : at + int(rng.integers(1, max_cut))] = b""
        elif op == 1:
            data[at:at] = junk[rng.integers(len(junk))]
        else:
            data = data[:at]
    return bytes(data)
