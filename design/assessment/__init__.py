"""A designed controller judged on the bridges it was not designed on: do no harm over the stated
uncertainty (``harm``, ``harm_fast``, ``harm_verdict``), one failed flap pair (``failsafe``),
actuator limits in turbulent wind (``actuator_study``), the usable speed with the actuators'
limits (``usable_speed``), the erection stages with flaps
(``erection_control``) and the acceptance checks ``bridgeflap optimise`` runs on its own
controller file (``acceptance``), and the design with its verdict folded into its status and
the public ``accept`` of any controller (``accept``).

May import: :mod:`bridgeflap.model` and the design layers below it (``io``, ``batch``, ``control``,
``sensitivity``).
"""
