"""Symbolic Lagrangian dynamics of a RobotModel, with the ordered steps that produce it.

    M(q) q'' + C(q, q') q' + g(q) + k(q) + F_v q' + F_c sign(q') = tau

``derive(robot)`` returns a ``Dynamics`` object holding every intermediate quantity (CoM positions
and velocities, link energies, M, Christoffel symbols, C, c, g, spring and friction terms, a minimal
linear parametrization Y a and the adaptive regressor Y_r) and the steps. All simplification goes
through the exact canonical form of app.core.trig, so results are compact and exact.

>>> from app.core.robot import load_robot
>>> dyn = derive(load_robot("planar_2r"))
>>> dyn.M[1, 1]
I2 + d2**2*m2
"""
from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import sympy as sp

from . import compact, model_cache, reproducible_sympy, steps, trig
from .compact import natural_angles, nice_coefficient, pretty, tidy  # noqa: F401 (pretty: public here too)
from .expressions import ExpressionError, NotStorable, dump_exact_list, load_exact_list, symbol
from .kinematics import Kinematics
from .mathtext import symbols_text
from .model_cache import ExprTable, as_list, as_mapping, as_text, as_texts, pair, sized
from .regressor import (_complexity, _independent_columns,  # noqa: F401 (_independent_columns: used by tasks)
                        _split_columns)
from .robot import DELTA, KNOWN_KINDS, RobotModel
from .steps import Step, shorthand_is_clear, to_latex
from .trig import TrigPoly


def _engine_version() -> str:
    """Hash of the engine's own source: any change to it invalidates the disk cache."""
    here = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for name in ("dynamics.py", "kinematics.py", "robot.py", "robot_model.py", "trig.py", "expressions.py",
                 "steps.py", "mathtext.py", "model_cache.py", "compact.py", "regressor.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()[:16]


ENGINE_VERSION = _engine_version()

Progress = Optional[Callable[[float, str], None]]


@dataclass
class Parametrization:
    """tau = Y(q, q', q'') a + y0 with a minimal set of dynamic coefficients a, and the adaptive
    regressor Y_r(q, q', q'_r, q''_r) with Y_r a + y0_r = M q''_r + C q'_r + g + k + F_v q'_r.

    y0 (``known_terms``) holds the terms with no unknown parameter at all, e.g. a spring whose
    stiffness is a plain number; it is zero for most robots."""
    Y: sp.Matrix
    a: List[sp.Expr]
    Y_ref: sp.Matrix
    known: List[str]
    unknown: List[str]
    known_terms: sp.Matrix
    known_terms_ref: sp.Matrix

    @property
    def count(self) -> int:
        return len(self.a)


@dataclass
class Dynamics:
    robot_name: str
    content_hash: str
    coordinates: List[str]
    parameters: List[str]
    com_positions: Dict[str, sp.Matrix]
    com_velocities: Dict[str, sp.Matrix]
    angular_velocities: Dict[str, sp.Matrix]       # in body frames
    kinetic: Dict[str, sp.Expr]                    # per body (and motor)
    potential: Dict[str, sp.Expr]                  # per body (gravity) and per spring
    M: sp.Matrix
    christoffel: List[sp.Matrix]                   # C_i with c_i = q'^T C_i q'
    C: sp.Matrix
    c: sp.Matrix
    g: sp.Matrix
    spring: sp.Matrix
    friction: sp.Matrix
    parametrization: Parametrization
    steps: List[Step] = field(default_factory=list)

    @property
    def q(self):
        return [symbol(c) for c in self.coordinates]

    @property
    def dq(self):
        return [symbol("d" + c) for c in self.coordinates]

    @property
    def ddq(self):
        return [symbol("dd" + c) for c in self.coordinates]

    def equations(self) -> sp.Matrix:
        """Left-hand side M q'' + c + g + k + friction (equal to the generalized forces)."""
        return (self.M * sp.Matrix(self.ddq) + self.c + self.g + self.spring + self.friction)

    # ------------------------------------------------------------------ stored as data
    _MATRICES = ("M", "C", "c", "g", "spring", "friction")
    _VECTOR_TABLES = ("com_positions", "com_velocities", "angular_velocities")
    _EXPR_TABLES = ("kinetic", "potential")

    def to_data(self) -> dict:
        """The model as JSON-ready data: texts, lists and integers that index one text of exact
        expressions (``dump_exact_list``), each distinct expression written once."""
        table = ExprTable()
        par = self.parametrization
        data = {"robot_name": self.robot_name, "content_hash": self.content_hash,
                "coordinates": list(self.coordinates), "parameters": list(self.parameters),
                "christoffel": [table.matrix(Ci) for Ci in self.christoffel],
                "steps": [[s.title, s.latex, s.text, s.highlight] for s in self.steps],
                "parametrization": {"Y": table.matrix(par.Y), "a": [table.index(e) for e in par.a],
                                    "Y_ref": table.matrix(par.Y_ref), "known": list(par.known),
                                    "unknown": list(par.unknown), "known_terms": table.matrix(par.known_terms),
                                    "known_terms_ref": table.matrix(par.known_terms_ref)}}
        for name in self._MATRICES:
            data[name] = table.matrix(getattr(self, name))
        for name in self._VECTOR_TABLES:
            data[name] = [[k, table.matrix(v)] for k, v in getattr(self, name).items()]
        for name in self._EXPR_TABLES:
            data[name] = [[k, table.index(v)] for k, v in getattr(self, name).items()]
        data["expressions"] = [len(table.exprs), dump_exact_list(table.exprs)]
        return data

    @classmethod
    def from_data(cls, data: dict) -> "Dynamics":
        """The model back from ``to_data``'s output, every field type-checked and every expression
        read through the whitelist (``load_exact_list``); raises ValueError/ExpressionError otherwise."""
        count, text = sized(data["expressions"], 2)
        if type(count) is not int:
            raise ValueError("stored model: bad expression count")
        table = ExprTable(load_exact_list(as_text(text), count))
        par = as_mapping(data["parametrization"])
        parametrization = Parametrization(
            Y=table.matrix_of(par["Y"]), a=[table.expr_of(e) for e in as_list(par["a"])],
            Y_ref=table.matrix_of(par["Y_ref"]), known=as_texts(par["known"]), unknown=as_texts(par["unknown"]),
            known_terms=table.matrix_of(par["known_terms"]), known_terms_ref=table.matrix_of(par["known_terms_ref"]))
        fields = {name: table.matrix_of(data[name]) for name in cls._MATRICES}
        for name in cls._VECTOR_TABLES:
            fields[name] = {as_text(k): table.matrix_of(v) for k, v in map(pair, as_list(data[name]))}
        for name in cls._EXPR_TABLES:
            fields[name] = {as_text(k): table.expr_of(v) for k, v in map(pair, as_list(data[name]))}
        steps = [Step(as_text(t), as_text(latex), as_text(text), _highlight(h))
                 for t, latex, text, h in (sized(s, 4) for s in as_list(data["steps"]))]
        return cls(robot_name=as_text(data["robot_name"]), content_hash=as_text(data["content_hash"]),
                   coordinates=as_texts(data["coordinates"]), parameters=as_texts(data["parameters"]),
                   christoffel=[table.matrix_of(m) for m in as_list(data["christoffel"])],
                   parametrization=parametrization, steps=steps, **fields)


#: beyond this many terms (trigonometric terms times the terms of their coefficients) in an entry of
#: c(q, dq) written out, C and c are written through the Christoffel matrices instead: a planar 7R's
#: c has 504 terms per entry, a 6R arm's with full inertia tensors thousands; the shipped robots at
#: most 42
LONG_ENTRY = 200


def _highlight(value) -> Dict[str, List[str]]:
    return {as_text(k): as_texts(v) for k, v in as_mapping(value).items()}


def _tp(expr) -> TrigPoly:
    return TrigPoly.from_expr(expr)


# ------------------------------------------------------------------------------ derivation
_memory: Dict[Tuple[str, str], Dynamics] = {}
_lock = threading.Lock()


def derive(robot: RobotModel, progress: Progress = None, use_cache: bool = True,
           known: Optional[Sequence[str]] = None) -> Dynamics:
    """Derive (or fetch from the memory/disk cache) the dynamic model of a robot.

    ``known`` lists the parameters treated as known data in the linear parametrization (default:
    every parameter of kind length, gravity or angle). The disk cache (app.core.model_cache)
    holds data only: exact expression texts read back through the whitelist parser."""
    key = (robot.content_hash or repr(robot), _known_key(known))
    with _lock:
        if use_cache and key in _memory:
            return _memory[key]
    envelope = _envelope(robot, known)
    path = cache_entry_path(robot, known)
    dyn = None
    if use_cache:
        payload = model_cache.read_entry(path, envelope)
        if payload is not None:
            try:
                dyn = Dynamics.from_data(payload)
            except (ExpressionError, NotStorable, KeyError, TypeError, ValueError, RecursionError):
                dyn = None      # a corrupt or crafted entry: derive again and overwrite it
    if dyn is None:
        reproducible_sympy.restart()
        dyn = _Deriver(robot, progress, known).run()
        if use_cache:
            try:
                model_cache.write_entry(path, envelope, dyn.to_data())
            except NotStorable:   # something the exact text cannot carry: memory only
                pass
    if use_cache:
        with _lock:
            _memory[key] = dyn
    return dyn


def _known_key(known) -> str:
    return ",".join(sorted(known)) if known is not None else "*"


def _envelope(robot: RobotModel, known) -> Dict[str, str]:
    return {"engine": ENGINE_VERSION, "robot": robot.content_hash, "known": _known_key(known)}


def cache_entry_path(robot: RobotModel, known: Optional[Sequence[str]] = None) -> Optional[Path]:
    """The disk-cache file of a robot's derivation (None for a robot without a file hash or
    without a usable cache folder)."""
    if not robot.content_hash:
        return None
    return model_cache.entry_path("|".join(_envelope(robot, known).values()))


def is_derived(robot: RobotModel, known: Optional[Sequence[str]] = None) -> bool:
    """Whether ``derive(robot, known=known)`` would be served by the memory or disk cache
    (without checking that a disk entry is intact)."""
    with _lock:
        if (robot.content_hash or repr(robot), _known_key(known)) in _memory:
            return True
    path = cache_entry_path(robot, known)
    return path is not None and path.is_file()


def forget_derivations() -> None:
    """Empty the in-memory caches of derivations, displayed coefficients and printed entries (not the
    disk cache, not sympy's own cache): the next ``derive`` works from scratch or from disk. Used by
    honest (cold) benchmarks."""
    with _lock:
        _memory.clear()
    compact.forget()
    steps.forget()
    trig.forget()
    from .numeric import forget_compiled        # here: the numeric package imports this module
    forget_compiled()                           # the compiled models hold their robot's derivation


class _Deriver:
    def __init__(self, robot: RobotModel, progress: Progress, known: Optional[Sequence[str]]):
        self.robot = robot
        self.kin = Kinematics(robot)
        self.q, self.dq, self.ddq = robot.q, robot.dq, robot.ddq
        self.n = robot.n
        self.progress = progress or (lambda fraction, message: None)
        self.steps: List[Step] = []
        if known is None:
            known = [p.name for p in robot.parameters.values() if p.kind in KNOWN_KINDS]
        unknown_names = set(known) - set(robot.parameters)
        if unknown_names:
            raise ValueError(f"unknown parameter(s) {sorted(unknown_names)} in 'known'")
        self.known = list(known)
        # products of sines and cosines of the links' angles shorten only double angles, which
        # robots whose revolute axes are all parallel do not have
        self.angles = [] if self.kin.parallel_revolute_axes() else natural_angles(self.kin)
        self.masses = [p.symbol for p in robot.parameters.values() if p.kind == "mass"]
        self.short_trig = shorthand_is_clear(robot.parameters)
        self._shown: Dict[frozenset, sp.Expr] = {}
        self.written_through = 0        # c's longest entry, when c is written through C_i (LONG_ENTRY)

    def quadratic_form(self, Mi) -> sp.Expr:
        """1/2 dq^T Mi dq written term by term: 1/2 m_jj dq_j^2 + m_jk dq_j dq_k."""
        dq, out = self.dq, []
        for j in range(self.n):
            for k in range(j, self.n):
                if Mi[j][k].terms:
                    factor = sp.Rational(1, 2) * dq[j] ** 2 if j == k else dq[j] * dq[k]
                    out.append(sp.Mul(factor, self.X(Mi[j][k]), evaluate=False))
        return sp.Add(*out)

    def X(self, tp: TrigPoly) -> sp.Expr:
        """The displayed form of a canonical polynomial (computed once per distinct polynomial)."""
        key = frozenset(tp.terms.items())
        shown = self._shown.get(key)
        if shown is None:
            shown = self._shown[key] = pretty(tp, self.angles, self.masses)
        return shown

    def MX(self, rows) -> sp.Matrix:
        return sp.Matrix([[self.X(e) for e in row] for row in rows])

    def L(self, expr) -> str:
        return to_latex(expr, self.robot.coordinates, short_trig=self.short_trig)

    def step(self, title, latex, text="", bodies=(), joints=()):
        hl = {}
        if bodies:
            hl["bodies"] = list(bodies)
        if joints:
            hl["joints"] = list(joints)
        self.steps.append(Step(title, latex, text, hl))

    # -------------------------------------------------------------- main
    def run(self) -> Dynamics:
        """The whole derivation, step by step: energies, M, g and springs, Christoffel symbols and
        C, friction, the equations of motion and the linear parametrization."""
        robot = self.robot
        self.progress(0.05, "kinematics")
        self._coordinates_step()
        energies = self._body_energies()
        M_tp, kinetic, potential = energies["M_tp"], energies["kinetic"], energies["potential"]
        self._motor_energies(M_tp, kinetic)
        self.progress(0.5, "inertia matrix")
        M = self.MX(M_tp)
        self.step("Inertia matrix", rf"M(q) = {self.L(M)}",
                  r"Collect $T = \frac{1}{2} \dot q^T M(q) \dot q$; $M$ is symmetric and positive definite.",
                  bodies=[b.name for b in robot.bodies])
        k_tp, spring_vec = self._springs(potential)
        self.progress(0.6, "gravity and springs")
        g_tp, g = self._gravity(energies["U_tp"], spring_vec)
        self.progress(0.7, "Christoffel symbols")
        christoffel, C_tp, C, c = self._christoffel(M_tp)
        fr, friction = self._friction()
        self._equations_step(M, c, g, spring_vec, friction)
        self.progress(0.8, "linear parametrization")
        param = self._parametrize(M_tp, C_tp, g_tp, k_tp, fr)
        self._parametrization_steps(param)
        self.progress(1.0, "done")
        return Dynamics(
            robot_name=robot.name, content_hash=robot.content_hash,
            coordinates=list(robot.coordinates), parameters=list(robot.parameters),
            com_positions=energies["positions"], com_velocities=energies["velocities"],
            angular_velocities=energies["omegas"],
            kinetic=kinetic, potential=potential, M=M, christoffel=christoffel, C=C, c=c, g=g,
            spring=spring_vec, friction=friction, parametrization=param, steps=self.steps)

    def _coordinates_step(self) -> None:
        self.step("Generalized coordinates",
                  r"q = " + self.L(sp.Matrix(self.q)) + r",\quad \dot q = " + self.L(sp.Matrix(self.dq)),
                  "The configuration is described by these coordinates; the model follows from the "
                  "Lagrangian $L = T - U$.")

    def _body_energies(self) -> dict:
        """Each body's kinematics and energies (two steps per body), summed into the inertia matrix
        and the gravitational potential as canonical polynomials: a dict with positions, velocities,
        omegas, kinetic, potential (per body), M_tp and U_tp."""
        robot, n = self.robot, self.n
        positions, velocities, omegas, kinetic, potential = {}, {}, {}, {}, {}
        shares = [[[] for _ in range(n)] for _ in range(n)]     # each body's share of M[j][k], k >= j
        U_tp = TrigPoly()
        dq = sp.Matrix(self.dq)
        gvec = robot.gravity
        for idx, body in enumerate(robot.bodies):
            self.progress(0.05 + 0.45 * idx / max(1, len(robot.bodies)), f"energy of {body.name}")
            p = self.kin.com_position(body.name)
            Jv = self.kin.point_jacobian(body.name, body.com)
            p = p.applyfunc(lambda e: tidy(e, self.angles, self.masses))
            v = (Jv * dq).applyfunc(lambda e: tidy(e, self.angles, self.masses))
            Jw = self.kin.angular_jacobian(body.name, in_body_frame=True)
            w = (Jw * dq).applyfunc(lambda e: tidy(e, self.angles, self.masses))
            positions[body.name], velocities[body.name], omegas[body.name] = p, v, w
            Mi = self._body_inertia(body, Jv, Jw)
            kinetic[body.name] = self.quadratic_form(Mi)
            for j in range(n):
                for k in range(j, n):
                    shares[j][k].append(Mi[j][k])
            Ui = TrigPoly()
            if body.mass != 0 and any(e != 0 for e in gvec):
                Ui = _tp(-body.mass * (gvec.T * p)[0])
            potential[body.name] = self.X(Ui)
            U_tp = U_tp + Ui
            self._body_steps(body.name, p, v, w, kinetic[body.name])
        M_tp = [[None] * n for _ in range(n)]
        for j in range(n):
            for k in range(j, n):
                M_tp[j][k] = M_tp[k][j] = TrigPoly.sum(shares[j][k])
        return {"positions": positions, "velocities": velocities, "omegas": omegas, "kinetic": kinetic,
                "potential": potential, "M_tp": M_tp, "U_tp": U_tp}

    def _body_inertia(self, body, Jv, Jw) -> List[List[TrigPoly]]:
        """One body's share of M(q): m Jv^T Jv + Jw^T I Jw, entry by entry (symmetric)."""
        n = self.n
        Jv_tp = [[_tp(Jv[r, k]) for k in range(n)] for r in range(3)]
        Jw_tp = [[_tp(Jw[r, k]) for k in range(n)] for r in range(3)]
        Mi = [[TrigPoly() for _ in range(n)] for _ in range(n)]
        I = body.inertia
        for j in range(n):
            for k in range(j, n):
                acc = []
                if body.mass != 0:
                    for r in range(3):
                        if Jv_tp[r][j].terms and Jv_tp[r][k].terms:
                            acc.append((Jv_tp[r][j] * Jv_tp[r][k]).scale(body.mass))
                for r in range(3):
                    for s in range(3):
                        if I[r, s] != 0 and Jw_tp[r][j].terms and Jw_tp[s][k].terms:
                            acc.append((Jw_tp[r][j] * Jw_tp[s][k]).scale(I[r, s]))
                Mi[j][k] = TrigPoly.sum(acc)
                if k != j:
                    Mi[k][j] = Mi[j][k]
        return Mi

    def _body_steps(self, label, p, v, w, kinetic) -> None:
        shown = label.replace("_", " ")
        text = (f"Centre of mass of {shown}: position, velocity, and angular velocity in its own frame; "
                r"then $T = \frac{1}{2} m \|v_c\|^2 + \frac{1}{2} \omega^T I \omega$.")
        latex = (rf"p_{{c,{label}}} = {self.L(p)},\quad v_{{c,{label}}} = {self.L(v)},\quad "
                 rf"\omega_{{{label}}} = {self.L(w)}")
        self.step(f"Kinematics of {shown}", latex, "Position of the centre of mass (base frame), its "
                  "velocity as the time derivative, and the link's angular velocity in its own frame.",
                  bodies=[label])
        self.step(f"Kinetic energy of {shown}", rf"T_{{{label}}} = {self.L(kinetic)}", text,
                  bodies=[label])

    def _motor_energies(self, M_tp, kinetic) -> None:
        """Rotor inertias of elastic joints, added to M_tp and kinetic in place."""
        dq = sp.Matrix(self.dq)
        for cname, inertia in self.robot.motor_inertias.items():
            k = self.robot.coordinates.index(cname)
            M_tp[k][k] = TrigPoly.sum([M_tp[k][k], TrigPoly.constant(inertia)])
            kinetic[f"motor {cname}"] = inertia * dq[k] ** 2 / 2
            self.step(f"Kinetic energy of the motor on {cname}",
                      rf"T_{{m}} = {self.L(kinetic[f'motor {cname}'])}",
                      "Rotor inertia (reduced model: only the rotor's own spin counts).")

    def _gravity(self, U_tp: TrigPoly, spring_vec):
        """g(q) = (dU/dq)^T as canonical polynomials and as shown, with the potential energy, gravity
        and spring-force steps."""
        robot = self.robot
        g_tp = [U_tp.diff(qk) for qk in self.q]
        g = sp.Matrix([self.X(e) for e in g_tp])
        if any(e != 0 for e in robot.gravity):
            self.step("Potential energy", rf"U(q) = {self.L(self.X(U_tp))}",
                      r"Gravity: $U_i = -m_i g^T p_{c,i}$ for each link.", bodies=[b.name for b in robot.bodies])
        self.step("Gravity vector", rf"g(q) = \left(\frac{{\partial U}}{{\partial q}}\right)^T = {self.L(g)}",
                  "Gradient of the gravitational potential energy.")
        if robot.springs:
            self.step("Spring forces", rf"k(q) = \left(\frac{{\partial U_e}}{{\partial q}}\right)^T = {self.L(spring_vec)}",
                      "Gradient of the elastic potential energy.")
        return g_tp, g

    def _christoffel(self, M_tp):
        """The Christoffel matrices C_i (a step each), C(q, dq) with c = C dq, and c(q, dq):
        returns (christoffel, C_tp, C, c)."""
        n, robot = self.n, self.robot
        dq = sp.Matrix(self.dq)
        dM = [[[M_tp[i][j].diff(qk) for qk in self.q] for j in range(n)] for i in range(n)]
        christoffel = []
        C_parts = [[[] for _ in range(n)] for _ in range(n)]
        for i in range(n):
            Ci_tp = [[(dM[i][j][k] + dM[i][k][j] - dM[j][k][i]).scale(sp.Rational(1, 2)) for k in range(n)]
                     for j in range(n)]
            Ci = self.MX(Ci_tp)
            christoffel.append(Ci)
            for j in range(n):
                for k in range(n):
                    if Ci_tp[j][k].terms:
                        C_parts[i][j].append(Ci_tp[j][k].scale(dq[k]))
            self.step(f"Christoffel matrix $C_{{{i + 1}}}$",
                      rf"C_{{{i + 1}}}(q) = \frac{{1}}{{2}}\left(\frac{{\partial m_{{{i + 1}}}}}{{\partial q}} + "
                      rf"\left(\frac{{\partial m_{{{i + 1}}}}}{{\partial q}}\right)^T - \frac{{\partial M}}{{\partial q_{{{i + 1}}}}}\right) = {self.L(Ci)}",
                      rf"Christoffel symbols of row {i + 1}; $c_{{{i + 1}}} = \dot q^T C_{{{i + 1}}} \dot q$.",
                      joints=[robot.bodies[min(i, len(robot.bodies) - 1)].name])
        C_tp = [[TrigPoly.sum(parts) for parts in row] for row in C_parts]
        c_tp = [TrigPoly.sum(C_tp[i][j].scale(dq[j]) for j in range(n)) for i in range(n)]
        longest = max(e.term_count() for e in c_tp)
        skew = r"Built from the Christoffel symbols, so that $\dot M - 2C$ is skew-symmetric."
        if longest <= LONG_ENTRY:
            C = self.MX(C_tp)
            c = sp.Matrix([self.X(e) for e in c_tp])
            self.step("Coriolis and centrifugal terms", rf"c(q,\dot q) = {self.L(c)}", r"$c_i = \dot q^T C_i \dot q$.")
            self.step(r"Factorization $c = C(q, \dot q)\, \dot q$", rf"C(q,\dot q) = {self.L(C)}", skew)
            return christoffel, C_tp, C, c
        # written out, c would be unreadable and slow to typeset: the Christoffel symbols shown above
        # are its intermediate variables (C and c hold the same values, nested instead of expanded)
        self.written_through = longest
        C = sp.Matrix(n, n, lambda i, j: sp.Add(*[christoffel[i][j, k] * dq[k] for k in range(n)]))
        c = sp.Matrix([sp.Add(*[C[i, j] * dq[j] for j in range(n)]) for i in range(n)])
        kept = (f"Written out, an entry has up to {longest} terms: it is kept through the Christoffel "
                "matrices above, as intermediate variables.")
        self.step("Coriolis and centrifugal terms",
                  rf"c_i(q,\dot q) = \dot q^T C_i(q)\, \dot q,\quad i = 1, \dots, {n}", kept)
        self.step(r"Factorization $c = C(q, \dot q)\, \dot q$",
                  rf"C_{{ij}}(q,\dot q) = \sum_{{k=1}}^{{{n}}} \left(C_i\right)_{{jk}}(q)\, \dot q_k", f"{skew} {kept}")
        return christoffel, C_tp, C, c

    def _friction(self):
        """Viscous and Coulomb joint friction: (the list of rows, the column tau_f) and its step."""
        robot = self.robot
        dq = sp.Matrix(self.dq)
        fr = robot.viscous_forces()
        for cname, coeff in robot.coulomb.items():
            k = robot.coordinates.index(cname)
            fr[k] += coeff * sp.sign(dq[k])
        friction = sp.Matrix(fr)
        if robot.has_friction:
            self.step("Friction", rf"\tau_f = {self.L(friction)}", "Viscous (and Coulomb) friction at the joints"
                      + (r"; a damper $d$ on a stretch $\delta$ adds $\left(\frac{\partial \delta}{\partial q}\right)^T "
                         r"d\,\dot\delta$." if robot.dampers else "."))
        return fr, friction

    def _equations_step(self, M, c, g, spring_vec, friction) -> None:
        robot = self.robot
        equation = (r"M(q)\ddot q + c(q,\dot q) + g(q)" + (r" + k(q)" if robot.springs else "")
                    + (r" + \tau_f" if robot.has_friction else "") + r" = \tau")
        if self.written_through:
            self.step("Equations of motion", equation, "The Euler-Lagrange equations, one row per coordinate, "
                      "with M, c and g as above (written out, a row would have more than "
                      f"{self.written_through} terms).")
            return
        lhs = M * sp.Matrix(self.ddq) + c + g + spring_vec + friction
        self.step("Equations of motion", rf"{equation},\quad {self.L(lhs)} = {self.L(sp.Matrix(self._tau_names()))}",
                  "The Euler-Lagrange equations, one row per coordinate.")

    def _parametrization_steps(self, param: Parametrization) -> None:
        has_y0 = any(e != 0 for e in param.known_terms)
        y0 = rf",\quad y_0 = {self.L(param.known_terms)}" if has_y0 else ""
        self.step("Linear parametrization", rf"Y(q,\dot q,\ddot q)\,a{' + y_0' if has_y0 else ''} = \tau,\quad "
                  rf"Y = {self.L(param.Y)},\quad a = {self.L(sp.Matrix(param.a))}{y0}",
                  f"A minimal set of {param.count} dynamic coefficients (known: {symbols_text(param.known)})"
                  + ("; $y_0$ collects the terms with no unknown parameter." if has_y0 else "."))
        y0r = rf",\quad y_{{0r}} = {self.L(param.known_terms_ref)}" if has_y0 else ""
        self.step("Adaptive regressor", rf"Y(q,\dot q,\dot q_r,\ddot q_r) = {self.L(param.Y_ref)}{y0r}",
                  r"$Y_r a = M \ddot q_r + C(q, \dot q) \dot q_r + g(q)$ (plus springs and friction): the Slotine-Li regressor.")

    def _springs(self, potential: Dict[str, sp.Expr]):
        """Elastic energy of each spring (a step each) and the spring forces k(q) = (dU_e/dq)^T, as
        canonical polynomials (for the regressor) and as shown: a nonlinear spring's force keeps its
        law, -K (theta - q) - K3 (theta - q)^3, rather than the expanded polynomial."""
        linear_tp, all_tp = TrigPoly(), TrigPoly()
        compact = [sp.Integer(0)] * self.n
        for spring in self.robot.springs:
            if spring.expr is not None:
                Ue = _tp(spring.potential())
            else:
                (ba, pa), (bb, pb) = spring.points
                d = self.kin.point_position(ba, pa) - self.kin.point_position(bb, pb)
                Ue = _tp(spring.stiffness * (d.T * d)[0] / 2)
            all_tp = all_tp + Ue
            if spring.is_linear:
                linear_tp = linear_tp + Ue
                potential[spring.name] = self.X(Ue)
            else:
                stretch = spring.expr - spring.rest
                potential[spring.name] = spring.potential()
                force = spring.force.xreplace({symbol(DELTA): stretch})
                compact = [c + sp.diff(stretch, qk) * force for c, qk in zip(compact, self.q)]
            self.step(f"Elastic energy of {spring.name}", rf"U_{{{spring.name}}} = {self.L(potential[spring.name])}",
                      "Potential energy stored in the spring.")
        k_tp = [all_tp.diff(qk) for qk in self.q]
        shown = sp.Matrix([self.X(linear_tp.diff(qk)) + c for qk, c in zip(self.q, compact)])
        return k_tp, shown

    def _tau_names(self):
        act = self.robot.actuated
        return [sp.Symbol(f"tau_{i + 1}") if act[i] else sp.Integer(0) for i in range(self.n)]

    # -------------------------------------------------------------- regressor
    def _parametrize(self, M_tp, C_tp, g_tp, k_tp, fr) -> Parametrization:
        n = self.n
        dq, ddq = self.dq, self.ddq
        dqr, ddqr = self.robot.reference_symbols()
        known = set(self.known)
        unknown_syms = [p.symbol for p in self.robot.parameters.values() if p.name not in known]

        def rows(acc, vel_for_C, vel_for_friction):
            out = []
            for i in range(n):
                t = []
                for j in range(n):
                    if M_tp[i][j].terms:
                        t.append(M_tp[i][j].scale(acc[j]))
                    if C_tp[i][j].terms:
                        t.append(C_tp[i][j].scale(vel_for_C[j]))
                f = fr[i].subs(dict(zip(dq, vel_for_friction))) if fr[i] != 0 else 0
                t += [g_tp[i], k_tp[i], _tp(f)]
                out.append(TrigPoly.sum(t))
            return out

        tau_rows = rows(ddq, dq, dq)
        ref_rows = rows(ddqr, dqr, dqr)
        cols, y0 = _split_columns(tau_rows, unknown_syms)
        ref_cols, y0_ref = _split_columns(ref_rows, unknown_syms)
        order = sorted(range(len(cols)), key=lambda k: (_complexity(cols[k][1]), k))
        basis, coeff = _independent_columns([cols[k] for k in order], known)
        Y = sp.Matrix(n, len(basis), lambda i, b: self.X(basis[b][1][i]))
        ref_map = {mono: vec for mono, vec in ref_cols}
        Y_ref = sp.Matrix(n, len(basis), lambda i, b: self.X(ref_map[basis[b][0]][i]) if basis[b][0] in ref_map else 0)
        a = [nice_coefficient(sp.expand(e), self.masses) for e in coeff]
        return Parametrization(Y, a, Y_ref, sorted(known), sorted(s.name for s in unknown_syms),
                               sp.Matrix([self.X(t) for t in y0]), sp.Matrix([self.X(t) for t in y0_ref]))


