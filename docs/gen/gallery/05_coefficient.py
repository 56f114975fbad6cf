"""N(t): the angle random walk of every window, with its 1-sigma band.

The noise model fitted to every window of the DAVAR surface at once
(`adavar.fit_noise(surface)`), here the angle random walk only, which is what white
noise is.
"""

import adavar
from adavar.plots import coefficient_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
surface = adavar.davar(scenario.data, window=600, rate=scenario.rate, taus="all")
trend = adavar.fit_noise(surface, terms=("angle_random_walk",))
fig = coefficient_figure(
    trend, term="angle_random_walk", conventional=False, title="N(t) of DAVAR-600"
)
