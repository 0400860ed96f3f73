"""The minimal linear parametrization of a model, tau = Y(q, q', q'') a + y0, found on the canonical
trigonometric polynomials: split every row into columns by monomials of the unknown parameters,
keep a greedy basis of independent columns (tested numerically at random points, combined exactly),
and fold each dependent column's monomial into the basis coefficients.

>>> from app.core.expressions import symbol
>>> m, l, q = symbol("m"), symbol("l"), symbol("q")
>>> cols, y0 = _split_columns([TrigPoly.from_expr(m*l*sp.cos(q) + m)], [m])
>>> [(str(psi), str(vec[0].to_expr())) for psi, vec in cols]
[('m', 'l*cos(q) + 1')]
"""
from __future__ import annotations

from typing import Dict, List, Tuple

import numpy as np
import sympy as sp

from .compact import polynomial_terms
from .trig import TrigPoly

_NUMPY = {sp.sin: np.sin, sp.cos: np.cos, sp.tan: np.tan, sp.exp: np.exp, sp.log: np.log, sp.Abs: np.abs,
          sp.sign: np.sign, sp.atan: np.arctan, sp.asin: np.arcsin, sp.acos: np.arccos}


def _monomials(coeff: sp.Expr, gens: List[sp.Symbol]):
    """``sympy.Poly(coeff, *gens).terms()`` computed directly for an expanded polynomial:
    [(exponents, coefficient)] in descending lexicographic order of the exponents."""
    parts = polynomial_terms(coeff)
    if parts is None:
        return sp.Poly(coeff, *gens).terms()
    index = {g: i for i, g in enumerate(gens)}
    groups: Dict[tuple, list] = {}
    for c, powers in parts:
        exps, rest = [0] * len(gens), []
        for s, e in powers.items():
            i = index.get(s)
            if i is None:
                rest.append(s ** e)
            else:
                exps[i] = e
        groups.setdefault(tuple(exps), []).append(c * sp.Mul(*rest))
    return [(m, sp.Add(*groups[m])) for m in sorted(groups, reverse=True)]


def _value(expr: sp.Expr, env, memo):
    """Numeric value of an expression with numpy arrays for its symbols (each subtree once)."""
    hit = memo.get(expr)
    if hit is not None:
        return hit
    if expr.is_Symbol:
        out = env[expr]
    elif expr.is_Number or expr.is_NumberSymbol:
        out = float(expr)
    elif expr.is_Add:
        out = sum(_value(a, env, memo) for a in expr.args)
    elif expr.is_Mul:
        out = 1.0
        for a in expr.args:
            out = out * _value(a, env, memo)
    elif expr.is_Pow and expr.exp.is_number:
        out = _value(expr.base, env, memo) ** float(expr.exp)
    elif type(expr) in _NUMPY:
        out = _NUMPY[type(expr)](*[_value(a, env, memo) for a in expr.args])
    else:
        syms = sorted(expr.free_symbols, key=lambda s: s.name)
        from .numeric import numeric_function       # here: the numeric package imports this module
        out = numeric_function(syms, expr, "numpy")(*[env[s] for s in syms])
    memo[expr] = out
    return out


def _trig_value(tp: TrigPoly, env, memo, npts: int) -> np.ndarray:
    total = np.zeros(npts)
    for key, coeff in tp.terms.items():
        basis = memo.get(key)
        if basis is None:
            freq, kind = key
            angle = sum(n * env[s] for s, n in freq) if freq else np.zeros(npts)
            basis = memo[key] = (np.cos(angle) if kind == "c" else np.sin(angle)) if freq else np.ones(npts)
        total = total + _value(coeff, env, memo) * basis
    return total


def _complexity(vec: List[TrigPoly]) -> Tuple[int, int]:
    terms = sum(tp.term_count() for tp in vec)
    return (terms, sum(sp.count_ops(c) for tp in vec for c in tp.terms.values()))


def _split_columns(rows: List[TrigPoly], unknown: List[sp.Symbol]):
    """tau_i = sum_psi Y_i,psi * psi + y0_i with psi monomials of the unknown parameters; returns
    the columns [(psi, [TrigPoly per row])] and y0 (the terms free of unknown parameters)."""
    columns: Dict[sp.Expr, List[Dict]] = {}
    order: List[sp.Expr] = []
    n = len(rows)
    for i, tp in enumerate(rows):
        for key, coeff in tp.terms.items():
            gens = unknown
            items = _monomials(coeff, unknown) if unknown else [((), coeff)]
            for monom, c in items:
                psi = sp.Mul(*[g ** e for g, e in zip(gens, monom)])
                if psi not in columns:
                    columns[psi] = [dict() for _ in range(n)]
                    order.append(psi)
                columns[psi][i][key] = columns[psi][i].get(key, 0) + c
    y0 = [TrigPoly(columns[sp.Integer(1)][i]) if sp.Integer(1) in columns else TrigPoly() for i in range(n)]
    return [(psi, [TrigPoly(columns[psi][i]) for i in range(n)]) for psi in order if psi != 1], y0


def _independent_columns(cols, known):
    """Greedy basis of the column space (over functions of the known parameters); dependent columns
    add their parameter monomial, times the exact combination coefficients, to the basis coefficients."""
    rng = np.random.default_rng(12345)
    syms = sorted(set().union(*[set().union(*[_free(tp) for tp in vec]) for _, vec in cols]) if cols else set(),
                  key=lambda s: s.name)
    known_syms = [s for s in syms if s.name in known]
    sample_syms = [s for s in syms if s.name not in known]
    known_vals = {s: float(rng.uniform(0.5, 1.5)) for s in known_syms}
    npts = 6 + 2 * len(cols)
    samples = {s: rng.uniform(-1.5, 1.5, npts) for s in sample_syms}
    env = {**{s: np.full(npts, v) for s, v in known_vals.items()}, **samples}
    memo: dict = {}
    numeric = [np.concatenate([_trig_value(tp, env, memo, npts) for tp in vec]) for _, vec in cols]
    basis, basis_num, coeffs, tables = [], [], [], {}
    for (psi, vec), num in zip(cols, numeric):
        if basis_num:
            A = np.column_stack(basis_num)
            lam, *_ = np.linalg.lstsq(A, num, rcond=None)
            resid = np.linalg.norm(A @ lam - num)
            scale = max(1.0, np.linalg.norm(num))
            dependent = resid < 1e-8 * scale
        else:
            dependent = np.linalg.norm(num) < 1e-12
            if dependent:
                continue
        if not dependent:
            basis.append((psi, vec))
            basis_num.append(num)
            coeffs.append(psi)
            continue
        lam_exact = _exact_combination([b[1] for b in basis], vec, known_syms, lam, tables)
        for b, l in enumerate(lam_exact):
            if l != 0:
                coeffs[b] = coeffs[b] + l * psi
    return basis, coeffs


def _free(tp: TrigPoly):
    out = set()
    for (freq, _), c in tp.terms.items():
        out |= c.free_symbols
        out |= {s for s, _ in freq}
    return out


def _exact_combination(basis_vecs, target, known_syms, lam_numeric=None, tables=None):
    """Exact lambda (functions of the known parameters) with target = sum lambda_b basis_b: one
    linear equation per row, basis function and monomial of the other symbols (velocities ...).
    ``tables`` remembers the equations of the basis columns between calls."""
    known = set(known_syms)
    tables = {} if tables is None else tables
    for vec in basis_vecs:
        if id(vec) not in tables:
            tables[id(vec)] = _equation_table(vec, known)
    columns = [tables[id(vec)] for vec in basis_vecs]
    wanted = _equation_table(target, known)
    keys = list(dict.fromkeys([k for t in columns for k in t] + list(wanted)))
    A = [[t.get(k, sp.S.Zero) for t in columns] for k in keys]
    b = [wanted.get(k, sp.S.Zero) for k in keys]
    return _solve_linear(A, b, known_syms)


def _equation_table(vec: List[TrigPoly], known) -> Dict[tuple, sp.Expr]:
    """{(row, basis function, monomial of the symbols that are not known parameters): coefficient}."""
    out: Dict[tuple, sp.Expr] = {}
    for i, tp in enumerate(vec):
        for key, coeff in tp.terms.items():
            other = sorted(coeff.free_symbols - known, key=lambda s: s.name)
            for monom, c in (_monomials(coeff, other) if other else [((), coeff)]):
                out[(i, key, tuple((s, e) for s, e in zip(other, monom) if e))] = c
    return out


def _solve_linear(A: List[list], b: list, known_syms) -> List[sp.Expr]:
    """Exact solution x of a consistent, possibly overdetermined linear system A x = b (lists of
    rows) whose coefficients are functions of the known parameters: pick independent equations
    numerically, solve them exactly, and verify the others."""
    k = len(A[0]) if A else 0
    rng = np.random.default_rng(7)
    point = {s: float(rng.uniform(0.5, 1.5)) for s in known_syms}
    memo: dict = {}
    rows: List[int] = []
    basis: List[np.ndarray] = []          # orthonormal span of the chosen rows
    for r, row in enumerate(A):
        v = np.array([_value(e, point, memo) for e in row], dtype=float)
        scale = np.linalg.norm(v)
        for u in basis:
            v = v - (u @ v) * u
        if scale > 0 and np.linalg.norm(v) > 1e-9 * scale:
            basis.append(v / np.linalg.norm(v))
            rows.append(r)
            if len(rows) == k:
                break
    if len(rows) < k:
        raise RuntimeError("internal error: the combination of regressor columns is not unique")
    sol = sp.Matrix([A[r] for r in rows]).LUsolve(sp.Matrix([b[r] for r in rows]))
    sol = [sp.factor(sp.cancel(v)) for v in sol]
    # the other equations must hold too: checked exactly at two random rational points (a nonzero
    # rational function of the known parameters vanishes there with probability zero)
    for seed in (11, 12):
        pick = np.random.default_rng(seed)
        at = {s: sp.Rational(int(pick.integers(3, 97)), int(pick.integers(3, 97))) for s in known_syms}
        x = [v.xreplace(at) for v in sol]
        for row, rhs in zip(A, b):
            residual = sp.Add(*[e.xreplace(at) * xi for e, xi in zip(row, x)]) - rhs.xreplace(at)
            if residual != 0 and not (residual.has(sp.Float) and abs(float(residual)) < 1e-9):
                raise RuntimeError("internal error: regressor columns combine inconsistently")
    return sol
