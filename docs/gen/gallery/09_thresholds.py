"""A fixed window's kurtosis against the thresholds K2 (the paper's Fig. 8).

Where the kurtosis of a window of 600 samples crosses 3.3, 3.45 and 4: the run above a
threshold starts when a kurtosis controller would start to shrink its window.
"""

import adavar
from adavar.paper.studies import threshold_study
from adavar.plots import threshold_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
fig = threshold_figure(threshold_study(scenario))
