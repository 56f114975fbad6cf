"""The dynamic Allan deviation as a surface (the paper's Fig. 4).

The A-DAVAR paper's scenario 1: 6000 s of unit white noise at 1 Hz whose standard
deviation is 3 between 3000 s and 4000 s, through a fixed window of 600 samples.
"""

import adavar
from adavar.plots import davar_surface_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
surface = adavar.davar(scenario.data, window=600, rate=scenario.rate, taus="all")
fig = davar_surface_figure(surface, title="DAVAR-600 of the paper's scenario 1")
