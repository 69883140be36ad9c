"""Numeric/symbolic backend of the aeroelastic assembly: one code path, two numerics.

The assembly (:mod:`bridgeflap.model.aeroelastic.assembly`) is written once with the handful of
functions below. Each dispatches on its arguments: numpy arrays and Python numbers give numpy
results (the numeric matrices of sweeps, p-k and plots), CasADi ``SX``/``MX``/``DM`` give CasADi
expressions (the named ``ca.Function`` objects of the optimiser). Plain arithmetic (``+``, ``*``,
``@``, ``.T``) already mixes numpy and CasADi correctly (CasADi takes precedence), so only
construction, slicing assignment, solves and concatenation need the shim -- the AeroSandbox
``aerosandbox.numpy`` pattern (STYLE.md, "One physics path, two numerics").

This is one of the two files of :mod:`bridgeflap.model` allowed to import CasADi (the other is
:mod:`bridgeflap.model.aeroelastic.symbolic`); ruff's banned-api rule (``TID251`` in
``pyproject.toml``) enforces it.
"""

from __future__ import annotations

import sys

import numpy as np

__all__ = [
    "Function",  # noqa: F822 - resolved on first use by the module __getattr__
    "as_numpy",
    "diag",
    "eye",
    "hcat",
    "is_symbolic",
    "jacobian",
    "kron",
    "matrix",
    "mtimes",
    "solve",
    "sym",
    "vcat",
    "zeros",
]


class _LazyCasadi:
    """``casadi``, imported on first use: a numeric-only run (``bridgeflap flutter``) never
    loads it, and no value can be a CasADi object before it is loaded (:func:`_types`)."""

    def __getattr__(self, name):
        import casadi

        return getattr(casadi, name)


ca = _LazyCasadi()


def _types(names: str) -> tuple:
    """CasADi's matrix types named in ``names`` (``"SX MX DM"``); empty while casadi is not
    loaded."""
    found = _TYPES.get(names)
    if found is None:
        mod = sys.modules.get("casadi")
        if mod is None:
            return ()
        found = _TYPES[names] = tuple(getattr(mod, n) for n in names.split())
    return found


_TYPES: dict[str, tuple] = {}


def __getattr__(name):  # ``Function`` = ``casadi.Function``, resolved on first use (PEP 562)
    if name == "Function":
        return ca.Function
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def is_symbolic(*values) -> bool:
    """True if any argument is a CasADi ``SX``/``MX`` expression."""
    return any(isinstance(v, _types("SX MX")) for v in values)


def _kind(values):
    """The CasADi matrix type of the first symbolic argument, ``None`` if all are numeric."""
    for v in values:
        if isinstance(v, _types("SX MX")):
            return type(v)
    return None


def zeros(rows: int, cols: int, like=(), dtype=float):
    """Zero matrix (rows, cols): CasADi of the kind of a symbolic entry of ``like``, else numpy."""
    kind = _kind(like)
    return np.zeros((rows, cols), dtype=dtype) if kind is None else kind.zeros(rows, cols)


def eye(n: int) -> np.ndarray:
    """Identity (numpy; mixes with CasADi in arithmetic)."""
    return np.eye(n)


def _cas(x, kind):
    if isinstance(x, _types("SX MX DM")):
        return x
    return kind(ca.DM(np.atleast_2d(np.asarray(x, dtype=float)) if np.ndim(x) else x))


def mtimes(*factors):
    """Matrix product of the factors (left to right)."""
    kind = _kind(factors)
    if kind is None and not any(isinstance(f, _types("DM")) for f in factors):
        out = factors[0]
        for f in factors[1:]:
            out = out @ f
        return out
    kind = kind or ca.DM
    return ca.mtimes([_cas(f, kind) for f in factors])


def solve(A, B):
    """``A^{-1} B``: numpy ``inv(A) @ B`` or CasADi ``solve``.

    The numeric path multiplies by the explicit inverse (LAPACK ``getri``) as the numeric
    assembly always has: the golden numbers (tests/test_golden.py) reproduce bit for bit, and
    for the small, well-conditioned mass matrices of a modal model the difference from an LU
    solve is round-off.
    """
    kind = _kind((A, B))
    if kind is None and not isinstance(A, _types("DM")) and not isinstance(B, _types("DM")):
        return np.linalg.inv(A) @ B
    kind = kind or ca.DM
    return ca.solve(_cas(A, kind), _cas(B, kind))


def hcat(blocks):
    """Horizontal concatenation."""
    kind = _kind(blocks)
    if kind is None:
        return np.hstack(blocks)
    return ca.horzcat(*[_cas(b, kind) for b in blocks])


def vcat(blocks):
    """Vertical concatenation."""
    kind = _kind(blocks)
    if kind is None:
        return np.vstack(blocks)
    return ca.vertcat(*[_cas(b, kind) for b in blocks])


def kron(a, b):
    """Kronecker product."""
    kind = _kind((a, b))
    if kind is None:
        return np.kron(a, b)
    return ca.kron(_cas(a, kind), _cas(b, kind))


def diag(v):
    """Diagonal matrix of a vector (numpy 1-D array or CasADi column)."""
    if isinstance(v, _types("SX MX DM")):
        return ca.diag(v)
    return np.diag(np.asarray(v).ravel())


def matrix(rows):
    """Matrix from nested lists of scalars (numbers or CasADi scalars)."""
    flat = [v for row in rows for v in row]
    kind = _kind(flat)
    if kind is None:
        return np.array(rows, dtype=float)
    return ca.vertcat(*[ca.horzcat(*row) for row in rows])


def sym(name: str, rows: int = 1):
    """A CasADi ``SX`` symbol column."""
    return ca.SX.sym(name, rows)


def jacobian(expr, x):
    """``d vec(expr) / dx`` as a CasADi expression."""
    return ca.jacobian(ca.vec(expr), x)


def as_numpy(x) -> np.ndarray:
    """Dense numpy array of a numeric value (numpy or CasADi ``DM``)."""
    if isinstance(x, _types("DM")):
        return np.asarray(x.full())
    return np.asarray(x)
