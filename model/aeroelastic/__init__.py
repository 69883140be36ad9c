"""The aeroelastic equations, assembled once: the numeric/symbolic backend (``backend``, one of
the two files that import CasADi), the one assembly (``assembly``), the state space
``A(U) = A0 + U A1 + U^2 A2`` (``statespace``), derivative-based loads on a structure
(``derivative_system``), the gust input of quasi-steady loads (``gust_input``), flaps and the
compensator K(s) (``flaps``, ``control``, ``controller_file``), the plant for control
engineers and python-control (``control_plant``, ``control_interop``; the conversions of K(s)
in ``python_control``), actuator limits (``actuator_limits``) and the named CasADi functions
of the design card (``symbolic``, the other CasADi file).

May import: the foundation, :mod:`bridgeflap.model.aero` and :mod:`bridgeflap.model.structure`.
"""
