"""The sliding kurtosis contribution coefficient S (the paper's Fig. 7).

S of the leading segment of the window: it reacts as soon as the new noise level enters
the window's leading edge, before the kurtosis of the whole window does.
"""

import adavar
from adavar.paper.studies import kurtosis_study
from adavar.plots import contribution_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
fig = contribution_figure(kurtosis_study(scenario))
