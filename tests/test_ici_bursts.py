"""A short burst of white noise is one ICI event, with a start and an end.

An audit (30 min at 100 Hz, N = 5e-3, the noise x5 for 5 s at 900 s) found
``adaptive_davar(..., method="ici")`` reporting, for one seed, a step at 900 s with no end
and a ramp from 903 to 906 s, for another two ramps. The segmentation cut the burst at both
edges, but the ramp-or-step test fitted the single step to block means (blocks of about
3 s at the default ``Lmax`` of 3 min): the block a burst's edge falls in has a mean between
the two levels, 25 times apart in variance, that a step at a block boundary misfits by far,
and a two-block ramp passes through. The step (and the ramp) may now end inside a block
(``adavar.dynamic.ici_episodes``).

Own generator (NumPy only). The committed matrix is a subset (``step=100``: the same
events, the episodes come from every centre); the long run (10 seeds each of 2, 5, 20 s
bursts at x3 and x5, x3 and x5 steps, a 2-min x3 ramp) is in the CHANGELOG.
"""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar.dynamic import ici_episodes as ep

RATE, SAMPLES, N = 100.0, 180_000, 5e-3  # 30 min at 100 Hz, N in deg/sqrt(s)
AT = 900.0


def noise(seed: int, kind: str, length: float = 5.0, factor: float = 5.0) -> np.ndarray:
    """White rate noise (discrete std ``N sqrt(rate)``) times ``factor`` over ``length`` s
    from ``AT`` (``burst``), from ``AT`` on (``step``) or growing linearly from 1 to
    ``factor`` over ``length`` s from ``AT`` (``ramp``)."""
    rng = np.random.default_rng(seed)
    x = N * np.sqrt(RATE) * rng.standard_normal(SAMPLES)
    t = np.arange(SAMPLES) / RATE
    if kind == "burst":
        x[(t >= AT) & (t < AT + length)] *= factor
    elif kind == "step":
        x[t >= AT] *= factor
    else:
        x *= 1.0 + (factor - 1.0) * np.clip((t - AT) / length, 0.0, 1.0)
    return x


def events(x: np.ndarray, **options) -> list[tuple[float, float | None, bool]]:
    r = adavar.adaptive_davar(x, rate=RATE, units="deg/s", method="ici", **options)
    return [(e.start_s, e.end_s, e.ramp) for e in r.events]


@pytest.mark.parametrize(
    ("length", "factor", "seed"), [(2.0, 3.0, 900), (5.0, 5.0, 901), (20.0, 3.0, 900)]
)
def test_burst_is_one_event_with_an_end(length, factor, seed):
    """Bursts of 2, 5 and 20 s, x3 or x5 (all six in the long run): one event from within
    0.2 s of the burst's start to within 0.2 s of its end, no ramp (the audit's seeds 900
    and 901; before: an open step and a ramp, or two ramps, for 5 and 20 s at x5)."""
    found = events(noise(seed, "burst", length, factor), step=100, ici_long_tau=False)
    assert len(found) == 1, found
    ((start, end, ramp),) = found
    assert not ramp and end is not None, found
    assert abs(start - AT) < 0.2 and abs(end - (AT + length)) < 0.2, found


def test_audit_record_as_reported():
    """The audit's call as it was made (every centre, long-tau terms on): one event
    (900, 905), not a step without end plus a ramp."""
    found = events(noise(900, "burst", 5.0, 5.0))
    assert len(found) == 1, found
    ((start, end, ramp),) = found
    assert not ramp and abs(start - 900) < 0.2 and abs(end - 905) < 0.2


def test_step_and_ramp_controls():
    """A lasting x5 step is one event without end (seed 3 gave a 6-s ramp before); a x3
    ramp over 2 min is one ramp=True event within 10 s of each end."""
    for seed in (3, 900):
        found = events(noise(seed, "step", factor=5.0), step=100, ici_long_tau=False)
        assert len(found) == 1, (seed, found)
        ((start, end, ramp),) = found
        assert not ramp and end is None and abs(start - AT) < 0.2, (seed, found)
    found = events(noise(900, "ramp", 120.0, 3.0), step=100, ici_long_tau=False)
    assert len(found) == 1, found
    ((start, end, ramp),) = found
    assert ramp and abs(start - AT) < 10 and abs(end - (AT + 120)) < 10, found


def test_edge_inside_a_block_is_a_step():
    """The building block: a x5 burst's edges fall inside the blocks of the ramp test; they
    are steps, and a 15-s ramp on the same blocks stays a ramp."""
    kw = dict(dispersion=3.0, clipped=3.3, gamma=3.0)
    lo, hi = 49_500, 131_000  # a region of the default Lmax (blocks of 318 samples)
    burst = ep.find_episodes(noise(901, "burst", 5.0, 5.0)[lo:hi], lo, **kw)
    assert [(e.ramp, e.rise) for e in burst] == [(False, True), (False, False)], burst
    assert abs(burst[0].start - 90_000) <= 3 and abs(burst[1].start - 90_500) <= 10, burst
    (ramp,) = ep.find_episodes(noise(901, "ramp", 15.0, 3.0)[lo:hi], lo, **kw)
    assert ramp.ramp and ramp.rise and ramp.statistic > 3.0**2
    assert abs(ramp.start - 90_000) < 400 and abs(ramp.end - 91_500) < 400
