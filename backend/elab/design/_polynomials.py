"""Polynomial coefficients in descending powers of s: round-off cleaning and printing."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

Coefficients = NDArray[np.float64]
_Number = Callable[[float, int], str]
_Power = Callable[[int], str]


def clean(coefficients: Coefficients, rel_tol: float) -> Coefficients:
    """Zero the coefficients below ``rel_tol`` times the largest, then drop leading zeros.

    The zero polynomial is returned as ``[0.0]``.
    """
    c = np.array(coefficients, dtype=np.float64)
    c[np.abs(c) < rel_tol * np.max(np.abs(c), initial=0.0)] = 0.0
    nonzero = np.flatnonzero(c)
    return c[nonzero[0] :] if nonzero.size else np.zeros(1)


def text(coefficients: Coefficients, precision: int) -> str:
    """``"65.11 s^2 + 2.314e+04"``: plain text, zero terms left out."""
    return _join(coefficients, precision, _text_number, lambda k: f"s^{k}")


def latex(coefficients: Coefficients, precision: int) -> str:
    """``"65.11 s^{2} + 2.314 \\times 10^{4}"``: LaTeX math, zero terms left out."""
    return _join(coefficients, precision, _latex_number, lambda k: f"s^{{{k}}}")


def _join(coefficients: Coefficients, precision: int, number: _Number, power: _Power) -> str:
    degree = len(coefficients) - 1
    parts: list[str] = []
    for k, c in enumerate(coefficients):
        if c == 0.0:
            continue
        n = degree - k
        magnitude = "" if abs(c) == 1.0 and n > 0 else number(abs(c), precision)
        variable = "" if n == 0 else ("s" if n == 1 else power(n))
        term = " ".join(p for p in (magnitude, variable) if p)
        sign = "-" if c < 0 else "+"
        parts.append(f"{sign} {term}" if parts else ("-" if c < 0 else "") + term)
    return " ".join(parts) if parts else "0"


def _text_number(x: float, precision: int) -> str:
    return f"{x:.{precision}g}"


def _latex_number(x: float, precision: int) -> str:
    mantissa, _, exponent = f"{x:.{precision}g}".partition("e")
    return f"{mantissa} \\times 10^{{{int(exponent)}}}" if exponent else mantissa
