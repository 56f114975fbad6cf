"""The Allan deviation of a MEMS gyro and its noise fit.

Half an hour of a simulated MEMS gyro at 100 Hz, with the output stage of a real part (a
20 Hz low-pass filter and a 16-bit word), its overlapping Allan deviation with 68 %
confidence bars, and the IEEE-952 terms the fit keeps. The taus where the filter makes
the curve roll off are left out of the fit and marked.
"""

import adavar
from adavar.plots import deviation_figure

gyro = adavar.simulate.sensor(
    180_000,
    rate=100.0,
    angle_random_walk=5e-3,
    bias_instability=2e-3,
    rate_random_walk=2e-4,
    bandwidth=20.0,
    lsb=1 / 262.4,
    seed=1,
)
result = adavar.deviation(gyro, stat="oadev", rate=100.0, taus="log", units="deg/s")
fit = adavar.fit_noise(result)
fig = deviation_figure(result, fit, title="Simulated MEMS gyro, 30 min at 100 Hz")
