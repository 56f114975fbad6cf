"""The kurtosis of windows of 11, 201 and 601 samples (the paper's Fig. 6).

The kurtosis of a window rises while the window holds a little of a different noise
level, and the longer the window the later and the wider the rise.
"""

import adavar
from adavar.paper.studies import kurtosis_study
from adavar.plots import kurtosis_windows_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
fig = kurtosis_windows_figure(kurtosis_study(scenario))
