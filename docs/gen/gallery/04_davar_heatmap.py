"""The same surface as a heat map.

Time along the horizontal axis, tau up the vertical one, the Allan deviation of each
window in colour; the disturbance of 3000-4000 s stands out over every tau.
"""

import adavar
from adavar.plots import davar_heatmap_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
surface = adavar.davar(scenario.data, window=600, rate=scenario.rate, taus="all")
fig = davar_heatmap_figure(surface, title="DAVAR-600, heat map")
