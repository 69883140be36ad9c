"""bridgeflap.model: physics of a suspension bridge with active deck flaps.

Conventions (stated once here and in the README; every module refers back)
---------------------------------------------------------------------------
* SI units everywhere. Any other unit is in the name (``frequency_hz``, ``angle_deg``).
* Deck heave ``h`` is positive **downward**; pitch ``alpha`` is positive **nose-up**
  (leading edge up, wind blowing from the leading edge); the pitching moment is taken about
  **mid-chord** (elastic axis at mid-chord, Theodorsen's ``a = 0``), positive nose-up.
* Lift ``L`` in the structural equations is positive **downward** (the seed paper's Eq. (2));
  Theodorsen's upward lift is ``-L``.
* ``b`` is the aerodynamic half-chord [m]; reduced frequency ``k = omega * b / U``;
  Laplace variable in aerodynamic time ``s_bar = s * b / U``.
* Theodorsen's apparent-inertia moment term ``-pi rho b^4 alpha_ddot / 8`` (seed Eq. (3)) is kept
  by default (``added_inertia=True``); bridge practice (Scanlan flat-plate derivatives) drops it.
* The three structural families (vertical, lateral, torsional) are uncoupled; aerodynamics
  couples vertical and torsional only (thin-aerofoil theory gives lift and moment, no drag).
* x is measured along the bridge from the north (Hessle) anchorage [m]; spans are listed
  north to south; "symmetric" refers to the main-span mid-point.
"""
