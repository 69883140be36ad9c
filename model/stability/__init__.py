"""Stability over a wind-speed grid: the eigenvalue sweep (``sweeps``), its result
(``result``) and the steps of a verified crossing it shares with the fast path
(``crossings``), branch tracking (``tracking``), the few-eigen-solution sweep with Newton's
Hopf and divergence points (``hopf``, ``hopf_newton``), the exact-Theodorsen p-k (``pk``,
``pk_kernel``), verified static divergence (``static_divergence``), mode-count convergence
(``convergence``), the flutter mode along the span (``modeshape``) and the root locus and
V-g/V-f figures (``plots``).

May import: the foundation, :mod:`bridgeflap.model.aero`, :mod:`bridgeflap.model.structure` and
:mod:`bridgeflap.model.aeroelastic`.
"""
