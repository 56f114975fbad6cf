"""The modified Allan deviation of a clock's phase.

Time-error (phase) samples of a clock, one a second for a day: white phase noise of
1 ns and white frequency noise of 1e-11. The modified Allan deviation separates the two
slopes (-3/2 and -1/2).
"""

import numpy as np

import adavar
from adavar.plots import deviation_figure

n = 86_400
white_pm = adavar.simulate.white(n, 1e-9, seed=2)  # s
white_fm = np.cumsum(adavar.simulate.white(n, 1e-11, seed=3))  # s (1 s steps)
phase = white_pm + white_fm
result = adavar.deviation(
    phase, stat="mdev", data_type="phase", tau0=1.0, taus="log", points_per_decade=5
)
fig = deviation_figure(result, title="Clock phase, 1 day at 1 s: MDEV")
