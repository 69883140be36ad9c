"""Stability over a wind-speed grid: the eigenvalue sweep and its crossings (``sweeps``), branch
tracking (``tracking``), the few-eigen-solution sweep with Newton's Hopf and divergence points
(``hopf``, ``hopf_newton``), the exact-Theodorsen p-k (``pk``, ``pk_kernel``), verified static
divergence (``static_divergence``), mode-count convergence (``convergence``) and the flutter
mode along the span (``modeshape``).

May import: the foundation, :mod:`model.aero`, :mod:`model.structure` and
:mod:`model.aeroelastic`.
"""
