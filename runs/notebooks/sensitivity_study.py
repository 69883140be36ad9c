# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Sensitivity study: which inputs move the Humber flutter and divergence speeds?
#
# Exact derivatives of the flutter speed `U_F` and the torsional-divergence speed `U_D` by the
# implicit-function theorem (`design.local_sensitivity`), each checked against a
# central finite difference of the fully re-solved pipeline. Cheap settings (6 modes, a 2 m/s
# grid, two parameters) so that CI runs it in seconds; the same call with the defaults is what
# `bridgeflap sensitivity` does.

# %%
# %matplotlib inline
import json
import subprocess
import sys

import numpy as np

from bridgeflap import design, model

PARAMETERS = ["deck.gj_nm2", "deck.half_chord_m"]
MODES, SPEEDS = 6, "0:120:2"
spec = model.load_bridge("humber")
res = design.local_sensitivity(spec, PARAMETERS, speeds=SPEEDS, n_modes=MODES)
print(res.table())
res  # the headline numbers

# %% [markdown]
# The relative derivative `(p/U) dU/dp` says how many per cent the speed moves for one per cent
# of the input: the tornado plot ranks the inputs.

# %%
fig = res.plot()

# %% [markdown]
# ## Checks
# 1. Each IFT derivative agrees with the central finite difference of the re-solved pipeline
#    (relative 1e-3: the difference step's truncation error is ~1e-5 here, the refined crossing
#    speeds are solved to 1e-7 m/s).
# 2. The command line gives the same numbers: `bridgeflap sensitivity --json` runs the same
#    function, so the nominal speeds and the derivatives agree to round-off (1e-9 relative).

# %%
for row in res.rows:
    ift, fd = row["d_flutter_speed"], row["d_flutter_speed_fd"]
    assert abs(ift - fd) <= 1e-3 * abs(fd), (row["parameter"], ift, fd)

cli = json.loads(subprocess.run(
    [sys.executable, "-m", "bridgeflap.design.cli.main", "sensitivity", "--parameters",
     ",".join(PARAMETERS),
     "--modes", str(MODES), "--speeds", SPEEDS, "--json"],
    capture_output=True, text=True, check=True).stdout)
assert np.isclose(cli["flutter_speed_m_s"], res.flutter_speed_m_s, rtol=1e-9, atol=0)
assert np.isclose(cli["divergence_speed_m_s"], res.divergence_speed_m_s, rtol=1e-9, atol=0)
for row in res.rows:
    d = cli["derivatives"][row["parameter"]]
    assert np.isclose(d["d_flutter_speed_m_s_per_unit"], row["d_flutter_speed"], rtol=1e-9, atol=0)
# a wider deck lowers the divergence speed (aerodynamic moment ~ b^2): the sign is physics
half_chord = next(r for r in res.rows if r["parameter"] == "deck.half_chord_m")
assert half_chord["relative_d_divergence_speed"] < 0
print(f"U_F = {res.flutter_speed_m_s:.3f} m/s, U_D = {res.divergence_speed_m_s:.3f} m/s; "
      "IFT = FD and = CLI")
