"""The buffeting term of the design objective, three ways.

``J_buf = 0.5 mean_U ((sigma_z / sigma_z0)^2 + (sigma_a / sigma_a0)^2)``: vertical and torsional
RMS at two main-span strips relative to the same loop with ``K = 0`` (flaps fitted, locked).

* :class:`ModalBuffeting` (``buffeting_term = "modal"``, the default): the spectral integral as
  a CasADi expression of the compensator coefficients (and the flap weights), written in modal
  coordinates. The compensator enters the closed-loop gust response only through the scalar
  ``K(j omega)`` (the structure of the analytic robust constraint,
  :mod:`bridgeflap.design.control.formulation.robust`), so the frequency data are computed once and
  each evaluation costs O(n_modes^2) per frequency.
* :class:`SymbolicBuffeting` (``"casadi"``): the same integral on the closed-loop state matrix
  (one dense 2 n_x solve per frequency in the graph): the cross-check, ~1000x slower to build.
* :class:`BuffetingCost` (``"callback"``): numpy
  :func:`bridgeflap.model.response.buffeting.buffeting` with a forward-difference gradient.

Used only when ``weight_buffeting > 0``.
"""

from __future__ import annotations

import os

import casadi as ca
import numpy as np

from bridgeflap.design.control.formulation.loop_algebra import _loop_block, k_complex
from bridgeflap.design.control.formulation.spectral_terms import gust_frequency_data, point_symbols


class BuffetingCost(ca.Callback):
    """``J_buf(p)``: closed-loop buffeting cost of ``problem``, forward-difference Jacobian."""

    def __init__(self, problem, n_p, step=1e-4):
        ca.Callback.__init__(self)
        self._prob = problem
        self._n_p = n_p
        self.step = step
        self._cache = {}
        self._jac = None
        self.construct("buffeting_cost", {})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._n_p, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(1, 1)

    def value(self, p):
        p = np.asarray(p, float).ravel()
        key = p.tobytes()
        if key not in self._cache:
            self._cache[key] = self._prob.buffeting_cost(p[:5], p[5:] if p.size > 5 else None)
        return self._cache[key]

    def eval(self, arg):
        return [ca.DM(self.value(arg[0]))]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        parent = self

        class _J(ca.Callback):
            def __init__(self):
                ca.Callback.__init__(self)
                self.construct(name, {})

            def get_n_in(self):
                return 2

            def get_n_out(self):
                return 1

            def get_sparsity_in(self, i):
                return ca.Sparsity.dense(parent._n_p, 1) if i == 0 else ca.Sparsity.dense(1, 1)

            def get_sparsity_out(self, i):
                return ca.Sparsity.dense(1, parent._n_p)

            def eval(self, arg):
                p = np.asarray(arg[0], float).ravel()
                f0 = parent.value(p)
                g = np.zeros(p.size)
                for k in range(p.size):
                    h = parent.step * max(1.0, abs(p[k]))
                    e = np.zeros(p.size)
                    e[k] = h
                    g[k] = (parent.value(p + e) - f0) / h
                return [ca.DM(g[None, :])]

        self._jac = _J()
        return self._jac


class SymbolicBuffeting:
    """``J_buf(theta, w)`` as the CasADi spectral integral of the design card.

    Per buffeting speed ``U``, :func:`bridgeflap.model.aeroelastic.symbolic.buffeting_rms_function`
    on the closed-loop functions ``A_cl(U, theta, w)``, ``B_gust(U, theta, w)`` of the one assembly:
    the one-sided spectral integral (trapezoid rule, frequency grid and load projection frozen at
    the reference design) of the vertical and the torsional RMS at two fixed strips -- the
    main-span strips where the reference closed loop's RMS is largest. Exactly
    differentiable in the compensator coefficients and the flap weights (CasADi AD), unlike
    :class:`BuffetingCost`. ``J_buf = 0.5 mean_U ((z / z0)^2 + (a / a0)^2)`` with ``z0, a0``
    the same integral with ``K = 0`` (flaps fitted, zero gain).

    Parameters
    ----------
    problem : bridgeflap.design.control.formulation.nlp.DesignProblem
    theta_ref, w_ref : array_like
        Reference design (frozen grid, strips): e.g. the start point.
    n_base, peaks_per_mode : int
        Grid of :func:`bridgeflap.model.spectral.adaptive_frequency_grid` (coarser than the numpy
        path: one dense 2 n_x solve per frequency in the expression graph).
    """

    def __init__(self, problem, theta_ref, w_ref=None, n_base=40, peaks_per_mode=15):
        from bridgeflap.model.aero.gust import gust_field
        from bridgeflap.model.aeroelastic.control import Compensator
        from bridgeflap.model.aeroelastic.symbolic import buffeting_rms_function
        from bridgeflap.model.response.buffeting import _main_span_mask, buffeting
        from bridgeflap.model.structure.loader import load_bridge

        s = problem.settings
        spec = problem.spec if problem.spec is not None else load_bridge(s.bridge)
        model = problem.model
        fun = model.casadi_functions()
        th0 = np.asarray(theta_ref, float)
        w0 = np.ones(model.n_flaps) if w_ref is None else np.asarray(w_ref, float)
        sys_cl = model.system(Compensator(*(float(v) for v in th0)), weights=w0)
        strip_x = np.asarray(model.open_loop.basis.strip_x, float)
        ns = strip_x.size
        main = _main_span_mask(spec, strip_x)
        ref = buffeting(sys_cl, np.asarray(s.buffeting_speeds_m_s, float), spec=spec,
                        n_modes=int(model.open_loop.basis.n))
        gust = gust_field(spec)
        th, w = ca.MX.sym("theta", 5), ca.MX.sym("w", model.n_flaps)
        k0 = ca.DM([0.0, 0.0, 0.0, float(th0[3]), float(th0[4])])
        terms, self.rows, self.omegas = [], [], []
        for i, U in enumerate(s.buffeting_speeds_m_s):
            jv = int(np.argmax(np.where(main, ref.rms_heave[i], -np.inf)))
            jt = int(np.argmax(np.where(main, ref.rms_pitch[i], -np.inf)))
            f, om = buffeting_rms_function(fun["A_cl"], fun["B_gust"], [ca.DM(th0), ca.DM(w0)],
                                           sys_cl.C_out, strip_x, float(U), gust,
                                           [jv, ns + jt], n_base=n_base,
                                           peaks_per_mode=peaks_per_mode)
            r0 = np.asarray(f(k0, ca.DM(w0)).full()).ravel()
            r = f(th, w)
            terms.append((r[0] / r0[0]) ** 2 + (r[1] / r0[1]) ** 2)
            self.rows.append((jv, ns + jt))
            self.omegas.append(om)
        self.function = ca.Function("J_buf", [th, w], [0.5 * sum(terms) / len(terms)],
                                    ["theta", "w"], ["J_buf"])

    def __call__(self, theta, w):
        return self.function(theta, w)


class ModalBuffeting:
    """``J_buf(theta, w)``: the CasADi spectral buffeting integral in modal coordinates.

    Closed loop (``beta = K alpha`` at every flap,
    :meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.gust_plant`)::

        q = (I - K N)^{-1} X_g w_tilde,   N = X diag(w) Pa,   X_g = D(j omega)^{-1} U P_gust

    with ``D`` the frozen-RFA dynamic matrix: ``D^{-1}`` is the exact transfer function of the
    RFA state space, so this is the integrand of
    :func:`bridgeflap.model.response.buffeting.reduced_response` for the closed loop. For an output
    row ``c`` (strip heave or pitch per modal coordinate) the one-sided PSD is ``G = y^T M
    conj(y)``, ``y = (I - K N)^{-T} c``, ``M = E S E^H`` (``E = X_g V^T``, ``S`` the projected load
    CSD ``s_w chi^2 V R V^T``,
    :func:`bridgeflap.model.aero.gust.coherence_projection``): ``M`` does not depend on the design
    and is computed once per frequency.

    With the layout fixed (``fixed_layout``; the default design), ``N = V diag(mu) V^{-1}`` once
    per frequency gives ``G = d^T H conj(d)``, ``d_i = 1 / (1 - K mu_i)``, ``H = diag(a) B
    diag(conj a)``, ``a = V^T c``, ``B = V^{-1} M V^{-H}``: a closed form in ``(Re K, Im K)``.
    Otherwise (flap placement, ``w`` a variable) one ``2 n`` real solve per frequency.

    The quadrature grid is frozen: per speed the union of the adaptive grids
    (:func:`bridgeflap.model.spectral.adaptive_frequency_grid`) of the open loop and of the
    reference design ``theta_ref`` closed loop. The strips are the main-span strips of largest
    open-loop RMS (vertical and torsional). :meth:`check` compares the frozen integral with the
    converged numpy path at any design (a posteriori).

    Parameters
    ----------
    problem : bridgeflap.design.control.formulation.nlp.DesignProblem
    theta_ref : array_like, optional
        Reference design for the grid (default: only the open-loop grid).
    fixed_layout : bool
        ``w`` fixed at ``problem.weights`` (closed form) or a variable (solve form).
    n_base, peaks_per_mode : int
        Grid settings (per reference system).
    """

    def __init__(self, problem, theta_ref=None, fixed_layout=True, n_base=80, peaks_per_mode=25,
                 half_widths=30.0):
        from bridgeflap.model.aero.gust import gust_field
        from bridgeflap.model.aeroelastic.control import Compensator
        from bridgeflap.model.response.buffeting import (
            _main_span_mask,
            buffeting,
            row_factor,
        )
        from bridgeflap.model.structure.loader import load_bridge

        s = problem.settings
        spec = problem.spec if problem.spec is not None else load_bridge(s.bridge)
        model = problem.model
        ol = model.open_loop
        basis = ol.basis
        self.weights = np.asarray(problem.weights, float)
        self.fixed_layout = bool(fixed_layout)
        #: buffeting speeds of a fixed layout built in the low-rank form because the loop
        #: matrix was nearly defective (the closed form needs its eigenvectors)
        self.defective_fallbacks = 0
        self.speeds_m_s = np.asarray(s.buffeting_speeds_m_s, float)
        strip_x = np.asarray(basis.strip_x, float)
        ns = strip_x.size
        main = _main_span_mask(spec, strip_x)
        gust = gust_field(spec)
        ref0 = buffeting(ol, self.speeds_m_s, spec=spec, n_modes=int(basis.n))
        self.open_loop_rms = (ref0.rms_vertical, ref0.rms_torsion)
        Pa = np.asarray(model.flaps.phi_a, float)
        self.rows, self.omegas = [], []
        _, Vt = row_factor(np.asarray(ol.aero.P_gust, float))   # speed-independent rows
        data = []        # per speed: (omega, X, M, C)
        for i, U in enumerate(self.speeds_m_s):
            jv = int(np.argmax(np.where(main, ref0.rms_heave[i], -np.inf)))
            jt = int(np.argmax(np.where(main, ref0.rms_pitch[i], -np.inf)))
            self.rows.append((jv, ns + jt))
            C = np.vstack([basis.phi_h[jv], basis.phi_a[jt]])       # (2, n)
            systems = [ol.A(U)]
            if theta_ref is not None:
                systems.append(model.system(Compensator(*(float(v) for v in theta_ref)),
                                            weights=self.weights).A(U))
            om, X, M = gust_frequency_data(model, gust, Vt, strip_x, float(U), systems,
                                           n_base, peaks_per_mode, half_widths)
            data.append((om, X, M, C))
            self.omegas.append(om)
        self.open_loop_var = np.array([[np.einsum("i,kij,j->", c, M, c).real for c in C]
                                       for (_, _, M, C) in data])       # (n_speeds, 2)
        self._build(Pa, data)

    def _build(self, Pa, data):
        th = ca.MX.sym("theta", 5)
        w = ca.MX.sym("w", Pa.shape[0])
        var = []
        low = None
        for om, X, M, C in data:
            if self.fixed_layout:
                try:
                    mu, Hs = _eig_point_data(Pa, X, M, C, self.weights)
                except np.linalg.LinAlgError:
                    # a nearly defective loop matrix at some frequency (e.g. a placed layout
                    # whose flaps' loop G is singular there): the low-rank form below is exact
                    # without eigenvectors
                    self.defective_fallbacks += 1
                else:
                    fm = _eig_point_function(Pa.shape[1]).map(om.size, "serial")
                    v = fm(th, ca.DM(om[None, :]), ca.DM(mu.real.T), ca.DM(mu.imag.T),
                           *[ca.DM(np.hstack(list(h))) for H in Hs for h in (H.real, H.imag)])
                    var.append(ca.sum2(v).T)
                    continue
            if low is None:
                US, V = _lowrank_pitch_map(Pa)
                f1 = _lowrank_point_function(US)
                if JIT:         # compiled like the closed form (falls back to the VM)
                    try:
                        f1, _ = _compiled(f1)
                    except Exception:  # noqa: BLE001 - no compiler: the same expression, VM
                        pass
                low = (V, f1)
            fm = low[1].map(om.size, "serial")
            v = fm(th, w, ca.DM(om[None, :]), *_lowrank_point_data(low[0], X, M, C))
            var.append(ca.sum2(v).T)
        V = ca.vertcat(*var)                                   # (n_speeds, 2) variances
        ratio = V / ca.DM(self.open_loop_var)
        self.variance_function = ca.Function("buffeting_variance", [th, w], [V],
                                             ["theta", "w"], ["variance"])
        self.function = ca.Function("J_buf", [th, w], [0.5 * ca.sum1(ca.sum2(ratio))
                                                       / len(data)], ["theta", "w"], ["J_buf"])
        # CasADi caches derivative functions weakly: held here, the gradient (compiled once
        # with JIT) survives from one nlpsol to the next instead of being rebuilt and
        # recompiled for every re-solve (measured: 3.1 s per nlpsol without, 0.25 s with)
        self._derivatives = [self.function.reverse(1)]

    def __call__(self, theta, w):
        return self.function(theta, w)

    def rms(self, theta, w=None) -> tuple[np.ndarray, np.ndarray]:
        """Vertical [m] and torsional [rad] RMS at the term's strips per speed (frozen grid)."""
        w = self.weights if w is None else np.asarray(w, float)
        v = np.sqrt(np.clip(np.asarray(self.variance_function(theta, w).full()), 0.0, None))
        return v[:, 0], v[:, 1]

    def check(self, problem, theta, w=None) -> dict:
        """The frozen integral against the numpy path (adaptive grid, converged to 5e-3) at
        ``theta``: the RMS at the same strips and the largest relative difference."""
        from bridgeflap.model.aeroelastic.control import Compensator
        from bridgeflap.model.response.buffeting import buffeting
        from bridgeflap.model.structure.loader import load_bridge

        w = self.weights if w is None else np.asarray(w, float)
        s = problem.settings
        spec = problem.spec if problem.spec is not None else load_bridge(s.bridge)
        sys_cl = problem.model.system(Compensator(*(float(v) for v in theta)), weights=w)
        r = buffeting(sys_cl, self.speeds_m_s, spec=spec,
                      n_modes=int(problem.model.open_loop.basis.n))
        ns = r.strip_x.size
        ref_v = np.array([r.rms_heave[i, jv] for i, (jv, _) in enumerate(self.rows)])
        ref_t = np.array([r.rms_pitch[i, jt - ns] for i, (_, jt) in enumerate(self.rows)])
        z, a = self.rms(theta, w)
        rel = max(float(np.max(np.abs(z - ref_v) / ref_v)),
                  float(np.max(np.abs(a - ref_t) / ref_t)))
        return {"rms_vertical_m": z.tolist(), "rms_torsion_rad": a.tolist(),
                "numpy_rms_vertical_m": ref_v.tolist(), "numpy_rms_torsion_rad": ref_t.tolist(),
                "max_relative_difference": rel, "grid_points": [int(o.size) for o in self.omegas]}


def _eig_point_data(Pa, X, M, C, weights):
    """Per frequency ``mu`` (n_omega, n) and ``H_p`` (n_omega, n, n) for both output rows."""
    XW = X * np.asarray(weights, float)[None, None, :]
    mu, V = np.linalg.eig(XW @ Pa[None, :, :])
    cond = np.linalg.cond(V)
    if np.any(cond > 1e8):
        raise np.linalg.LinAlgError(f"loop matrix nearly defective (cond(V) {cond.max():.2e})")
    Vi = np.linalg.inv(V)
    B = Vi @ M @ np.conj(np.swapaxes(Vi, 1, 2))
    Hs = []
    for c in C:
        a = np.einsum("i,kij->kj", c, V)                    # a = V^T c
        Hs.append(a[:, :, None] * B * np.conj(a)[:, None, :])
    return mu, Hs


#: Compile the closed-form point function and its reverse derivative (CasADi code generation,
#: the system compiler ``$CC`` or ``cc``, ``-O1``): on the default card (16 modes, 2,847
#: frequencies) one value of ``J_buf`` takes 5 ms instead of 27 ms and value plus gradient
#: 18-20 ms instead of 96 ms (measured on this machine). The compile (``-O1``: as fast as
#: ``-O2`` here, quicker to build) takes ~2-4 s; the library is kept in :func:`_library_dir`
#: under a hash of its source, compiler and flags, so later processes load it in ~5 ms (the
#: two starts of a design, the inner designs of a critical-speed search, every later run).
#: Without a working compiler the CasADi virtual machine evaluates the same expression
#: (:data:`JIT_STATUS` says which); ``tests/test_buffeting_term.py`` checks both agree to 1e-12.
JIT = True
#: ``"compiled"``, ``"compiled (cached library)"``, ``"virtual machine (compile failed:
#: ...)"`` or ``"not built"``: the outcome of this process's build of the point function
JIT_STATUS = "not built"
#: Compiler flags of the point-function library (part of its cache key).
JIT_FLAGS = ("-O1", "-shared", "-fPIC")
_JIT_OPTIONS = {"jit": True, "compiler": "shell",
                "jit_options": {"flags": ["-O1"], "verbose": False}}
_POINT_CACHE: dict = {}
_JIT_DIR = None


def _jit_options() -> dict:
    """:data:`_JIT_OPTIONS` writing the generated C and the libraries into a directory of this
    process under ``$TMPDIR/bridgeflap_jit_<uid>/``, never into the user's working directory
    (CasADi's default). CasADi leaves its files behind at exit, so the directories of processes
    that no longer run are removed here, before this process adds its own."""
    global _JIT_DIR
    if _JIT_DIR is None:
        import shutil
        import tempfile

        uid = os.getuid() if hasattr(os, "getuid") else "user"
        root = os.path.join(tempfile.gettempdir(), f"bridgeflap_jit_{uid}")
        os.makedirs(root, exist_ok=True)
        for name in os.listdir(root):
            if name.isdigit() and not _alive(int(name)):
                shutil.rmtree(os.path.join(root, name), ignore_errors=True)
        _JIT_DIR = os.path.join(root, str(os.getpid()))
        os.makedirs(_JIT_DIR, exist_ok=True)
    return dict(_JIT_OPTIONS,
                jit_options=dict(_JIT_OPTIONS["jit_options"], directory=_JIT_DIR + os.sep))


def _library_dir() -> str:
    """Directory of the compiled point-function libraries: ``$BRIDGEFLAP_CACHE_DIR/jit``, else
    ``$XDG_CACHE_HOME/bridgeflap/jit`` or ``~/.cache/bridgeflap/jit`` (kept between
    processes, private to the user); when none can be created, this process's temporary
    directory (:func:`_jit_options`)."""
    base = os.environ.get("BRIDGEFLAP_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
        "bridgeflap")
    path = os.path.join(base, "jit")
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        if os.access(path, os.W_OK | os.X_OK):
            return path
    except OSError:
        pass
    _jit_options()
    return _JIT_DIR


def _compiled(f, reverse=True) -> tuple[ca.Function, str]:
    """``f`` (an SX function) as a compiled library with its reverse derivative
    (``adj1_<name>``, which CasADi's external functions use for gradients), from
    :func:`_library_dir` when a library of the same source, compiler and flags is there,
    else compiled into it (written under a temporary name, then renamed: concurrent
    processes never load a half-written file). Returns the function and its status."""
    import hashlib
    import subprocess

    name = f.name()
    cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    cg.add(f)
    if reverse:         # (a function that carries its own derivative outputs needs none)
        cg.add(f.reverse(1))
    src = cg.dump()
    cc = os.environ.get("CC", "cc")
    key = hashlib.sha256("\0".join([src, cc, *JIT_FLAGS, ca.__version__]).encode()).hexdigest()
    d = _library_dir()
    lib = os.path.join(d, f"{name}_{key[:24]}.so")
    if os.path.exists(lib):
        try:
            return ca.external(name, lib), "compiled (cached library)"
        except Exception:  # noqa: BLE001 - unreadable or foreign file: rebuilt below
            pass
    tmp = os.path.join(d, f".{name}_{key[:24]}_{os.getpid()}")
    try:
        with open(tmp + ".c", "w", encoding="utf-8") as fh:
            fh.write(src)
        subprocess.run([cc, *JIT_FLAGS, tmp + ".c", "-o", tmp + ".so", "-lm"], check=True,
                       capture_output=True, timeout=600)
        os.replace(tmp + ".so", lib)
    finally:
        for ext in (".c", ".so"):
            if os.path.exists(tmp + ext):
                os.remove(tmp + ext)
    return ca.external(name, lib), "compiled"


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (signal 0); unknown counts as running."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _eig_point_function(n, jit=None) -> ca.Function:
    """The closed-form point function for ``n`` modes, compiled when ``jit`` (default
    :data:`JIT`) and a compiler works; cached per process."""
    global JIT_STATUS
    jit = JIT if jit is None else bool(jit)
    key = (int(n), jit)
    if key not in _POINT_CACHE:
        f = _eig_point_expression(n)
        if jit:
            try:
                f, JIT_STATUS = _compiled(ca.Function(f"buffeting_point_c{int(n)}", f.sx_in(),
                                                      f.call(f.sx_in())))
            except Exception as exc:  # noqa: BLE001 - no compiler: the same expression, VM
                msg = (str(exc).splitlines() or [type(exc).__name__])[0]
                JIT_STATUS = f"virtual machine (compile failed: {msg})"
        _POINT_CACHE[key] = f
    return _POINT_CACHE[key]


def _eig_point_expression(n) -> ca.Function:
    inputs, _, (g1, g2) = point_symbols(n)
    return ca.Function("buffeting_point", inputs, [ca.vertcat(g1, g2)])


def _lowrank_pitch_map(Pa) -> tuple[np.ndarray, np.ndarray]:
    """``(U_r S, V_r)`` of ``Phi_a = U_r S V_r^T`` truncated at
    ``bridgeflap.design.control.formulation.loop_algebra.LOWRANK_RTOL``
    (rank 4 for 25 flaps on 16 modes: only the torsional modes pitch)."""
    from bridgeflap.design.control.formulation.loop_algebra import LOWRANK_RTOL

    U, s, Vt = np.linalg.svd(np.asarray(Pa, float), full_matrices=False)
    r = max(1, int(np.sum(s > LOWRANK_RTOL * s[0]))) if s.size and s[0] > 0 else 1
    return U[:, :r] * s[:r], Vt[:r].T


def _lowrank_point_data(V, X, M, C) -> list:
    """Per frequency data of :func:`_lowrank_point_function` as horizontally stacked DMs:
    ``E = V_r^T X`` (r x n_flaps), ``C X`` (2 x n_flaps), ``c M c^T`` (2), ``V_r^T M c^T``
    (r x 2) and ``V_r^T M V_r`` (r x r); complex ones as real and imaginary parts."""
    E = np.einsum("ir,kif->krf", V, X)
    CX = np.einsum("pi,kif->kpf", C, X)
    m0 = np.einsum("pi,kij,pj->kp", C, M, C).real
    m1 = np.einsum("ir,kij,pj->krp", V, M, C)
    M2 = np.einsum("ir,kij,js->krs", V, M, V)
    out = []
    for a in (E, CX):
        out += [ca.DM(np.hstack(list(a.real))), ca.DM(np.hstack(list(a.imag)))]
    out.append(ca.DM(m0.T))
    for a in (m1, M2):
        out += [ca.DM(np.hstack(list(a.real))), ca.DM(np.hstack(list(a.imag)))]
    return out


def _lowrank_point_function(US) -> ca.Function:
    """The placement form of one frequency's variances (w a variable): ``z_p M z_p^H`` for the
    two output rows ``c_p``, ``z_p = c_p (I - K X W Phi_a)^{-1}``, in the low-rank form of
    ``Phi_a = U_r S V_r^T``. Woodbury: ``z_p = c_p + K a_p V_r^T`` with ``a_p = c_p X W U_r S
    (I_r - K G)^{-1}``, ``G = V_r^T X W U_r S``, so ``z_p M z_p^H = c_p M c_p^T + 2 Re(K a_p
    V_r^T M c_p^T) + |K|^2 a_p (V_r^T M V_r) a_p^H``: one r x r complex solve per frequency
    instead of an n_modes one (exact; SX, real arithmetic, exact derivatives in theta and w).
    """
    US = np.asarray(US, float)
    nF, r = US.shape
    th, w, om = ca.SX.sym("theta", 5), ca.SX.sym("w", nF), ca.SX.sym("omega")
    Er, Ei = ca.SX.sym("Er", r, nF), ca.SX.sym("Ei", r, nF)
    Br, Bi = ca.SX.sym("CXr", 2, nF), ca.SX.sym("CXi", 2, nF)
    m0 = ca.SX.sym("m0", 2)
    m1r, m1i = ca.SX.sym("m1r", r, 2), ca.SX.sym("m1i", r, 2)
    Hr, Hi = ca.SX.sym("M2r", r, r), ca.SX.sym("M2i", r, r)
    Kr, Ki = k_complex(th, om)
    W = ca.repmat(w.T, r, 1)
    Gr, Gi = ca.mtimes(Er * W, ca.DM(US)), ca.mtimes(Ei * W, ca.DM(US))
    W2 = ca.repmat(w.T, 2, 1)
    Rr, Ri = ca.mtimes(Br * W2, ca.DM(US)), ca.mtimes(Bi * W2, ca.DM(US))     # (2, r)
    # a (I - K G) = R  <=>  (I - K G^T) a^T = R^T
    A = ca.solve(_loop_block(Kr, Ki, Gr.T, Gi.T), ca.vertcat(Rr.T, Ri.T))
    ar, ai = A[:r, :], A[r:, :]                                            # (r, 2): a_p^T
    out = []
    for p in range(2):
        xr, xi = ar[:, p], ai[:, p]
        tr = ca.dot(xr, m1r[:, p]) - ca.dot(xi, m1i[:, p])
        ti = ca.dot(xr, m1i[:, p]) + ca.dot(xi, m1r[:, p])
        quad = (ca.dot(xr, ca.mtimes(Hr.T, xr)) + ca.dot(xi, ca.mtimes(Hr.T, xi))
                + 2.0 * ca.dot(xr, ca.mtimes(Hi, xi)))
        out.append(m0[p] + 2.0 * (Kr * tr - Ki * ti) + (Kr * Kr + Ki * Ki) * quad)
    return ca.Function("buffeting_point_lowrank",
                       [th, w, om, Er, Ei, Br, Bi, m0, m1r, m1i, Hr, Hi], [ca.vertcat(*out)])


def buffeting_objective(problem, theta0, weights0, th, w, p):
    """``J_buf`` as an expression of the NLP's ``th`` and ``w`` (or ``p = [th; z]``) for
    ``problem.settings.buffeting_term``; the term is built once per problem and layout kind
    (the grid frozen at the first solve's start) and reused by every re-solve."""
    s = problem.settings
    kind = s.buffeting_term
    if kind == "callback":
        cb = BuffetingCost(problem, problem.n_p)
        problem.callbacks["buffeting"] = cb
        return cb(p)
    key = ("buffeting", kind, bool(s.optimise_placement))
    if key not in problem.callbacks:
        w_ref = problem.weights if weights0 is None else np.asarray(weights0, float)
        if kind == "casadi":
            problem.callbacks[key] = SymbolicBuffeting(problem, theta0, w_ref)
        else:
            problem.callbacks[key] = ModalBuffeting(problem, theta0,
                                                    fixed_layout=not s.optimise_placement)
    return problem.callbacks[key](th, w)
