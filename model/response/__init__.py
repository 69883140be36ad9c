"""Response to turbulence: buffeting RMS from the spectral integral (``buffeting``,
``buffeting_inputs``), the random-response engine of a stable LTI system (``spectral``), its
independent white-noise and Monte-Carlo checks (``simulation``) and the time-domain closed
loop with flap angle and rate limits (``actuator_sim``).

May import: the foundation, :mod:`model.aero`, :mod:`model.structure`,
:mod:`model.aeroelastic` and :mod:`model.stability`.
"""
