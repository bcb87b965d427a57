"""Arguments checked exactly before a stage runs: a count is a whole number (``spp=2.5`` is
refused, never truncated), a range has step 1 (``range(0, 4, 2)`` is refused), a size is two
whole numbers of at least 1, a switch is a bool, a number is a real number. Each refusal is
a :class:`FemtoError` naming the keyword as the caller spelled it (``spp=2.5: ...``).
The library then checks the values' ranges as it checks the command's flags."""

from __future__ import annotations

import numbers
import os
from typing import Any, Optional, Tuple

import numpy as np

from ._errors import FemtoError


def _is_bool(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))


def whole(name: str, value: Any, lo: int = 0, hi: Optional[int] = None) -> int:
    """``value`` as an int: an integer, or a float with no fractional part, in ``lo..=hi``."""
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise FemtoError(f"{name}={value!r}: expected a whole number")
    if isinstance(value, numbers.Integral):
        n = int(value)
    else:
        f = float(value)
        if not f.is_integer():
            raise FemtoError(f"{name}={value!r}: expected a whole number, not a fraction")
        n = int(f)
    if n < lo:
        raise FemtoError(f"{name}={value!r}: must be at least {lo}")
    if hi is not None and n > hi:
        raise FemtoError(f"{name}={value!r}: must be at most {hi}")
    return n


def opt_whole(name: str, value: Any, lo: int = 0, hi: Optional[int] = None) -> Optional[int]:
    return None if value is None else whole(name, value, lo, hi)


def number(name: str, value: Any) -> float:
    """``value`` as a float: a real number (not a bool or a string)."""
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise FemtoError(f"{name}={value!r}: expected a number")
    return float(value)


def opt_number(name: str, value: Any) -> Optional[float]:
    return None if value is None else number(name, value)


def switch(name: str, value: Any) -> bool:
    """``value`` as a bool: ``True`` or ``False`` only."""
    if not _is_bool(value):
        raise FemtoError(f"{name}={value!r}: expected True or False")
    return bool(value)


def text(name: str, value: Any) -> str:
    if not isinstance(value, str):
        raise FemtoError(f"{name}={value!r}: expected a string")
    return value


def opt_text(name: str, value: Any) -> Optional[str]:
    return None if value is None else text(name, value)


def path(name: str, value: Any) -> Optional[str]:
    """A path (str or os.PathLike), or a :class:`Cube` (its file), or None."""
    if value is None:
        return None
    if hasattr(value, "path") and not isinstance(value, (str, bytes, os.PathLike)):
        value = value.path  # a femto.Cube
    if not isinstance(value, (str, os.PathLike)):
        raise FemtoError(f"{name}={value!r}: expected a path")
    return os.fspath(value)


def point(name: str, value: Any) -> Optional[list]:
    """Three real numbers (x, y, z), or None."""
    if value is None:
        return None
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != 3 or isinstance(value, str):
        raise FemtoError(f"{name}={value!r}: expected three numbers (x, y, z)")
    return [number(name, v) for v in items]


def pair(name: str, value: Any) -> Optional[Tuple[float, float]]:
    """Two real numbers, or None."""
    if value is None:
        return None
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != 2 or isinstance(value, str):
        raise FemtoError(f"{name}={value!r}: expected two numbers")
    return number(name, items[0]), number(name, items[1])


def size(name: str, value: Any) -> Optional[Tuple[int, int]]:
    """``"640x480"`` or ``(640, 480)``: two whole numbers of at least 1, or None."""
    if value is None:
        return None
    expected = f"{name}={value!r}: expected WIDTHxHEIGHT, two whole numbers of at least 1, " \
        "e.g. \"640x480\" or (640, 480)"
    if isinstance(value, str):
        w, sep, h = value.strip().lower().partition("x")
        if not sep or not w.strip().isdigit() or not h.strip().isdigit():
            raise FemtoError(expected)
        items = [int(w), int(h)]
    else:
        try:
            items = list(value)
        except TypeError:
            raise FemtoError(expected) from None
        if len(items) != 2:
            raise FemtoError(expected)
    try:
        w, h = (whole(name, v, 1) for v in items)
    except FemtoError:
        raise FemtoError(expected) from None
    return w, h


def span(name: str, value: Any, example: str) -> Optional[Tuple[int, int]]:
    """``"A..B"``, ``range(A, B)`` or ``(A, B)`` as (A, B): whole numbers, ``0 <= A``, step 1
    (``example``: the command's wording, e.g. ``"frame B excluded, e.g. 0..50"``)."""
    if value is None:
        return None
    expected = f"{name}={value!r}: expected A..B with 0 <= A < B, {example}"
    if isinstance(value, range):
        if value.step != 1:
            raise FemtoError(
                f"{name}={value!r}: a range of step {value.step}; {name} takes every one of "
                f"A..B (step 1), {example}"
            )
        items = [value.start, value.stop]
    elif isinstance(value, str):
        a, sep, b = value.partition("..")
        if not sep or not a.strip().isdigit() or not b.strip().isdigit():
            raise FemtoError(expected)
        items = [int(a), int(b)]
    else:
        try:
            items = list(value)
        except TypeError:
            raise FemtoError(expected) from None
        if len(items) != 2:
            raise FemtoError(expected)
    try:
        a, b = (whole(name, v, 0) for v in items)
    except FemtoError:
        raise FemtoError(expected) from None
    return a, b


def array_values(name: str, value: Any) -> np.ndarray:
    """A numpy array of real numbers (integers or floats), as C-ordered float32 (the array
    itself when it is one already, not a copy); refused: booleans, complex numbers, strings,
    objects, and values float32 cannot hold."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise FemtoError(
            f"{name}: an array of dtype {a.dtype}: expected real numbers (integers or floats)"
        )
    if a.dtype.kind == "f" and a.dtype.itemsize > 4:
        with np.errstate(over="ignore"):
            b = a.astype(np.float32)
        beyond = np.isinf(b) & np.isfinite(a)
        if beyond.any():
            at = tuple(int(i) for i in np.argwhere(beyond)[0])
            raise FemtoError(
                f"{name}[{', '.join(map(str, at))}] = {a[at].item()!r}: beyond float32's range "
                "(a cube holds float32 values)"
            )
        return np.ascontiguousarray(b)
    return np.ascontiguousarray(a, dtype=np.float32)


def mask_values(name: str, value: Any) -> Optional[np.ndarray]:
    """A mask of booleans or of the integers 0 and 1 (1 = valid pixel), as uint8."""
    if value is None:
        return None
    m = np.asarray(value)
    if m.dtype.kind not in "biu":
        raise FemtoError(f"{name}: an array of dtype {m.dtype}: expected booleans or 0 and 1")
    if m.size and m.dtype.kind != "b":
        bad = (m != 0) & (m != 1)
        if bad.any():
            at = tuple(int(i) for i in np.argwhere(bad)[0])
            raise FemtoError(
                f"{name}[{', '.join(map(str, at))}] = {m[at].item()!r}: expected 0 or 1 (1 = valid pixel)"
            )
    return np.ascontiguousarray(m, dtype=np.uint8)


def compression(name: str, value: Any) -> Optional[str]:
    """``"none"`` or a deflate level 0-9 (an int, or its digits), or None (the default)."""
    if value is None or isinstance(value, str):
        return value
    return str(whole(name, value, 0, 9))
