"""Response to turbulence: buffeting RMS from the spectral integral (``buffeting``,
``buffeting_inputs``; the random-response engine itself is the foundation's
:mod:`bridgeflap.model.spectral`, shared with the CasADi integral), independent white-noise and
Monte-Carlo checks (``simulation``), the time-domain closed loop with flap angle and rate
limits (``actuator_sim``) and the buffeting figures (``plots``).

May import: the foundation, :mod:`bridgeflap.model.aero`, :mod:`bridgeflap.model.structure`,
:mod:`bridgeflap.model.aeroelastic` and :mod:`bridgeflap.model.stability`.
"""
