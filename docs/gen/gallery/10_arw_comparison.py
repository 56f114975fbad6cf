"""N(t) of DAVAR-400, DAVAR-600, DAVAR-K and A-DAVAR (the paper's Fig. 12).

The four methods on the same realisation of scenario 1, with the true level: the short
window tracks the changes and scatters, the long one is smooth and late, A-DAVAR follows
the long window where the noise is stationary and the short one around the changes.
"""

import adavar
from adavar.plots import arw_comparison_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
comparison = adavar.compare(scenario, taus="octave")
fig = arw_comparison_figure(comparison)
