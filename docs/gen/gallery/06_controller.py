"""The adaptive window's controller (the paper's Fig. 10).

The kurtosis of each window, the sliding kurtosis contribution coefficient S of its
leading segment, the controller's flags and the window length, centre by centre, with the
paper's settings (Lmax 600, Lmin 400, l 100, K1 2.5, K2 3.3, S2 0.07).
"""

import numpy as np

import adavar
from adavar.plots import controller_figure

scenario = adavar.simulate.paper_scenario(1, seed=2018)
schedule = adavar.adaptive_schedule(scenario.data, rate=scenario.rate, lmax=600, lmin=400, l=100)
time = np.arange(len(scenario.data)) / scenario.rate
fig = controller_figure(
    schedule, time, change_times=scenario.change_times, title="A-DAVAR controller on scenario 1"
)
