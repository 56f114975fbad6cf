"""Numerical robustness (issue 14): masked arrays, any scale, impossible rates, warnings,
level steps in the DAVAR windows, and one-line errors for every user mistake."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar.core.errors import AdavarInputError
from adavar.fit.noise_model import MAX_REWEIGHT
from adavar.stats import stream
from adavar.stats.statistics import MAX_POINTS_PER_DECADE, STATISTICS

from . import reference


def _noise(n, seed=0):
    return np.random.default_rng(seed).standard_normal(n)


def _one_line(excinfo):
    text = str(excinfo.value)
    assert "\n" not in text and text, text
    return text


# ---------------------------------------------------------------------------------------
# item 2: a masked array's mask is not silently dropped


def _masked(n=2000):
    x = np.ma.masked_array(_noise(n, seed=1), mask=np.zeros(n, dtype=bool))
    x[100:110] = 1e6  # what lies under the mask must never be read
    x[100:110] = np.ma.masked
    return x


_MASK_CALLS = {
    "deviation": lambda x: adavar.deviation(x),
    "deviation chunked": lambda x: adavar.deviation(x, chunk_size=512),
    "davar": lambda x: adavar.davar(x, window=300, taus="octave"),
    "davar chunked": lambda x: adavar.davar(x, window=300, taus="octave", chunk_size=512),
    "adaptive_davar": lambda x: adavar.adaptive_davar(x, lmax=200, lmin=100, l=20),
    "adaptive_schedule chunked": lambda x: adavar.adaptive_schedule(
        x, lmax=200, lmin=100, l=20, chunk_size=512
    ),
    "sliding_kurtosis": lambda x: adavar.sliding_kurtosis(x, window=300),
    "kurtosis_contribution": lambda x: adavar.kurtosis_contribution(x, window=300, segment=50),
}


@pytest.mark.parametrize("name", sorted(_MASK_CALLS))
def test_masked_samples_are_refused_with_the_way_out(name):
    with pytest.raises(AdavarInputError, match="masked") as excinfo:
        _MASK_CALLS[name](_masked())
    text = _one_line(excinfo)
    assert "sample 100" in text and "filled(np.nan)" in text


def test_a_masked_array_without_masked_samples_is_its_data():
    x = _noise(2000, seed=2)
    got = adavar.deviation(np.ma.masked_array(x, mask=np.zeros(x.size, dtype=bool)))
    np.testing.assert_array_equal(got.dev, adavar.deviation(x).dev)


# ---------------------------------------------------------------------------------------
# item 11: every statistic is homogeneous, computed at scale 1


def _at_scale(x, k):
    """``y = x * 2**k`` as stored, and the values of ``y`` at scale 1 (exact: ``y * 2**-k``)."""
    y = np.ldexp(x, k)
    return y, np.ldexp(y, -k)


_DEV_FIELDS = ("dev", "dev_low", "dev_high")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    stat=st.sampled_from(STATISTICS),
    data_type=st.sampled_from(["rate", "phase"]),
    k=st.one_of(st.integers(-1060, 1020), st.sampled_from([-1060, -500, 500, 1020])),
    seed=st.integers(0, 50),
)
def test_property_deviation_scales_exactly(stat, data_type, k, seed):
    x = _noise(600, seed=seed) / 5.0 + (0.5 if seed % 2 else 0.0)  # |x| < 2**1 mostly
    x = np.clip(x, -1.9, 1.9)
    y, x1 = _at_scale(x, k)
    got = adavar.deviation(y, stat=stat, data_type=data_type, tau0=0.5)
    want = adavar.deviation(x1, stat=stat, data_type=data_type, tau0=0.5)
    for name in _DEV_FIELDS:  # the same value, rounded once to the scale (even subnormal)
        np.testing.assert_array_equal(getattr(got, name), np.ldexp(getattr(want, name), k))
    for name in ("tau", "m", "n", "edf", "alpha"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


def test_near_the_float_limit_and_subnormal_records():
    x = _noise(4000, seed=3)
    for k, label in ((1017, "1e306"), (500, "1e150"), (-530, "1e-160"), (-1060, "subnormal")):
        y, x1 = _at_scale(x / 8.0, k)
        got = adavar.deviation(y)
        want = np.ldexp(adavar.deviation(x1).dev, k)
        assert np.all(got.dev > 0), label  # subnormals used to read as a constant record
        np.testing.assert_array_equal(got.dev, want, err_msg=label)
    chunked = adavar.deviation(np.ldexp(x, 1017), chunk_size=1000)  # out of core: a few ulps
    np.testing.assert_allclose(chunked.dev, adavar.deviation(np.ldexp(x, 1017)).dev, rtol=1e-14)


def test_a_deviation_beyond_float_max_is_an_error_not_inf():
    x = np.cumsum(_noise(4000, seed=4)) * 1e305  # a random walk: TDEV grows past 1.8e308
    with pytest.raises(AdavarInputError, match="exceed the float64 range") as excinfo:
        adavar.deviation(x, stat="tdev", tau0=1e3)
    _one_line(excinfo)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    k=st.one_of(st.integers(-480, 480), st.sampled_from([-480, 480, 0])),
    data_type=st.sampled_from(["rate", "phase"]),
    step=st.sampled_from([1, 7]),
    seed=st.integers(0, 20),
)
def test_property_davar_scales_exactly(k, data_type, step, seed):
    x = _noise(900, seed=seed) / 4.0
    y, x1 = _at_scale(x, k)
    kw = dict(window=120, taus="octave", step=step, data_type=data_type, tau0=0.25)
    got, want = adavar.davar(y, **kw), adavar.davar(x1, **kw)
    np.testing.assert_array_equal(got.avar, np.ldexp(want.avar, 2 * k))
    np.testing.assert_array_equal(got.alpha, want.alpha)


@pytest.mark.parametrize("k", [-600, 600])
def test_davar_variances_outside_float64_are_an_error(k):
    """Variances near 4**±600 cannot be stored: a one-line error instead of inf or zeros."""
    y = np.ldexp(_noise(1000, seed=5), k)
    for kw in ({}, {"chunk_size": 300}):
        with pytest.raises(AdavarInputError, match="float64 range") as excinfo:
            adavar.davar(y, window=100, taus="octave", **kw)
        _one_line(excinfo)


def test_davar_out_of_core_and_lazy_scale_exactly():
    da = pytest.importorskip("dask.array")
    x = _noise(3000, seed=6)
    y = np.ldexp(x, 450)
    want = np.ldexp(adavar.davar(x, window=200, taus="octave").avar, 900)
    chunked = adavar.davar(y, window=200, taus="octave", chunk_size=700)
    np.testing.assert_allclose(chunked.avar, want, rtol=1e-14)
    lazy = adavar.davar(da.from_array(y, chunks=500), window=200, taus="octave", confidence=None)
    np.testing.assert_allclose(lazy.avar.compute(), want, rtol=1e-14)


@pytest.mark.parametrize("k", [-1060, -700, 300, 1017])
def test_kurtosis_and_the_adaptive_controller_are_scale_free(k):
    x = _noise(3000, seed=7)
    x = x / np.abs(x).max()  # |x| <= 1: k = 1024 - 7 keeps every sample finite
    y, x1 = _at_scale(x, k)
    for f in (
        lambda d: adavar.sliding_kurtosis(d, window=200),
        lambda d: adavar.kurtosis_contribution(d, window=200, segment=50),
        lambda d: adavar.kurtosis_contribution(d, window=200, reference="record"),
    ):
        np.testing.assert_array_equal(f(y), f(x1))
    got = adavar.adaptive_schedule(y, lmax=300, lmin=200, l=50)
    want = adavar.adaptive_schedule(x1, lmax=300, lmin=200, l=50)
    np.testing.assert_array_equal(got.kurtosis, want.kurtosis)
    np.testing.assert_array_equal(got.window, want.window)
    assert np.isfinite(got.kurtosis).all()


def test_kurtosis_of_mixed_signs_at_the_float_limit():
    x = _noise(3000, seed=8)
    x = x / np.abs(x).max() * (1 - 2**-52)
    y, x1 = _at_scale(x, 1024)  # |y| up to 1.797e308: y - anchor overflowed
    np.testing.assert_array_equal(
        adavar.sliding_kurtosis(y, window=200), adavar.sliding_kurtosis(x1, window=200)
    )


def _to_an_ulp(got, want):
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=0.0, equal_nan=True)


@pytest.mark.parametrize("k", [-300, -150, 150, 300])
def test_fit_scales_with_the_square_of_the_data(k):
    rng = np.random.default_rng(9)
    x = rng.standard_normal(20000) + np.cumsum(rng.standard_normal(20000)) * 1e-2
    y, x1 = _at_scale(x, k)
    for method in ("gls", "wls", "slopes"):
        got = adavar.fit_noise(adavar.deviation(y, rate=10.0), method=method)
        want = adavar.fit_noise(adavar.deviation(x1, rate=10.0), method=method)
        # the least-squares fits are exact; the slope read-offs work in logs (to an ulp)
        same = np.testing.assert_array_equal if method != "slopes" else _to_an_ulp
        same(got.coefficients, np.ldexp(want.coefficients, 2 * k))
        same(got.coefficient_uncertainty, np.ldexp(want.coefficient_uncertainty, 2 * k))
        if method == "gls" and abs(k) < 250:
            np.testing.assert_array_equal(
                got.coefficient_covariance, np.ldexp(want.coefficient_covariance, 4 * k)
            )
        np.testing.assert_array_equal(got.residuals, want.residuals)
        for name, value in want.slopes.values.items():
            _to_an_ulp(got.slopes.values[name], math.ldexp(value, k))
            _to_an_ulp(got.slopes.uncertainty[name], math.ldexp(want.slopes.uncertainty[name], k))
    surface = adavar.fit_noise(adavar.davar(y, window=3000, rate=10.0, taus="octave", step=500))
    plain = adavar.fit_noise(adavar.davar(x1, window=3000, rate=10.0, taus="octave", step=500))
    np.testing.assert_array_equal(surface.coefficients, np.ldexp(plain.coefficients, 2 * k))


# ---------------------------------------------------------------------------------------
# item 13: impossible rates, and no RuntimeWarning on valid input


@pytest.mark.parametrize("rate", [1e-308, 1e-310, 1e308, 1e100, 1e-50])
def test_an_impossible_rate_is_an_input_error(rate):
    x = _noise(500, seed=10)
    for call in (
        lambda: adavar.deviation(x, rate=rate),
        lambda: adavar.davar(x, window=100, rate=rate),
        lambda: adavar.adaptive_davar(x, lmax=100, lmin=60, l=10, rate=rate),
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(AdavarInputError) as excinfo:
                call()
        assert "rate" in _one_line(excinfo)


def test_a_time_axis_that_overflows_is_an_input_error():
    # a rate of 1e-308 Hz once reached the time axis ("time of the last centre"); the
    # rate bound (adavar.core.settings.RATE_LIMITS) now refuses it first, by its unit
    with pytest.raises(AdavarInputError, match=r"rate = 1e-308 Hz lies outside"):
        adavar.davar(_noise(100), window=3, taus=[1e308], rate=1e-308)


def _valid_calls():
    x = _noise(3000, seed=11)
    flat = x.copy()
    flat[1000:1400] = 2.0  # constant windows: NaN kurtosis, zero variances, unfitted rows
    yield lambda: adavar.deviation(np.full(200, 3.0), stat="mdev")
    yield lambda: adavar.deviation(np.ldexp(x, 1017), stat="totdev")
    yield lambda: adavar.deviation(np.ldexp(x, -1060), data_type="phase", rate=1e12)
    yield lambda: adavar.fit_noise(adavar.deviation(np.ldexp(x, 300), rate=100.0)).warnings
    yield lambda: adavar.davar(x, window=3, taus="all").adev_high
    yield lambda: adavar.davar(flat, window=300, taus="octave", confidence=0.999).adev_low
    yield lambda: adavar.fit_noise(adavar.davar(flat, window=200, taus="octave", step=20)).p_value
    yield lambda: adavar.sliding_kurtosis(flat, window=50)
    yield lambda: adavar.kurtosis_contribution(flat, window=50, segment=10)
    yield lambda: adavar.adaptive_davar(flat, lmax=200, lmin=100, l=20, taus="octave").adev


def test_no_runtime_warning_escapes_from_valid_input():
    for call in _valid_calls():
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            call()


# ---------------------------------------------------------------------------------------
# item 15: DAVAR after a huge level step, against a brute-force window


def _brute_davar(x, L, ms):
    """Each window (mirror-extended) straight from its definition, exactly.

    Every sample is an integer multiple of the record's coarsest common power-of-two
    quantum, so the window's sums and second differences are exact in int64; only the
    squares round (once each) before ``math.fsum``.
    """
    x = np.asarray(x, dtype=np.float64)
    e = int(np.min(np.frexp(x[x != 0])[1])) - 53
    while np.all(np.mod(np.ldexp(x, -(e + 1)), 1.0) == 0):
        e += 1
    ints = np.ldexp(x, -e)
    assert np.abs(ints).max() < 2.0**62
    ext = np.pad(ints.astype(np.int64), L, mode="symmetric")
    out = np.full((x.size, len(ms)), np.nan)
    for p in range(x.size):
        a = p - (L - 1) // 2 + L
        s = np.concatenate([[0], np.cumsum(ext[a : a + L] - ext[a])])
        for j, m in enumerate(ms):
            m = int(m)
            if 3 * m <= L:
                d = s[2 * m :] - 2 * s[m:-m] + s[: -2 * m]
                assert np.abs(d).max() < 2**53  # exact as a double
                d = d.astype(np.float64)
                out[p, j] = math.ldexp(math.fsum(d * d), 2 * e) / (2.0 * m * m * d.size)
    return out


def _step_record(n, dtype, offset, step):
    x = _noise(n, seed=12)
    x[n // 2 :] += step
    return (x + offset).astype(dtype)


@pytest.mark.parametrize(
    "dtype, offset, step", [(np.float64, 1e9, 1e6), (np.float32, 1e5, 1e6)], ids=["f64", "f32"]
)
def test_davar_after_a_huge_level_step_matches_brute_force(dtype, offset, step):
    """White noise of sigma 1, a level step of 1e6 sigma in the middle, a 1e9 offset."""
    x = _step_record(4000, dtype, offset, step)
    L = 300
    res = adavar.davar(x, window=L, taus="octave", confidence=None)
    want = _brute_davar(x, L, res.m)
    worst = float(np.max(np.abs(res.avar / want - 1.0)))
    assert worst < 1e-15, worst  # 2.2e-16; the anchored phase gave 9.7e-9 (f64)
    chunked = adavar.davar(x, window=L, taus="octave", confidence=None, chunk_size=1500)
    np.testing.assert_allclose(chunked.avar, want, rtol=1e-15)


def test_davar_after_a_huge_step_in_phase_data_and_sparse_centres():
    x = _step_record(3000, np.float64, 1e9, 1e6)
    L = 200
    res = adavar.davar(x, window=L, taus="octave", confidence=None, step=401)
    want = _brute_davar(x, L, res.m)
    assert float(np.max(np.abs(res.avar / want[res.centre] - 1.0))) < 1e-15
    # phase input: the increments of the integrated record (cumsum rounds, diff is exact)
    phase = np.concatenate([[0.0], np.cumsum(x)])
    got = adavar.davar(phase, window=L, taus="octave", confidence=None, data_type="phase")
    want = _brute_davar(np.diff(phase), L, res.m)
    assert float(np.max(np.abs(got.avar / want - 1.0))) < 1e-15


@pytest.mark.parametrize("size", [1e8, 1e12])
@pytest.mark.parametrize("kind", ["step", "spike"])
def test_windows_next_to_a_huge_excursion_lose_no_digits(kind, size):
    """A step or spike of 1e12 sigma costs nothing in the quiet windows around it."""
    x = _noise(2400, seed=16)
    if kind == "step":
        x[1100:] += size
    else:
        x[1000:1010] *= size
    res = adavar.davar(x, window=40, taus="octave", confidence=None)
    worst = 0.0
    for lo, hi in ((1010, 1400), (1600, 2000)):  # quiet windows after it (fsum reference)
        centre, _, _, want = reference.davar_reference(x[lo:hi], 40, edges="valid", ms=res.m)
        worst = max(worst, float(np.max(np.abs(res.avar[lo + centre] / want - 1.0))))
    assert worst < 1e-15, worst  # the anchored phase: 2e-13 * size (step), 1e-16 * size


# ---------------------------------------------------------------------------------------
# items 10 and 19: every user mistake is a one-line AdavarInputError


def _result():
    return adavar.deviation(_noise(2000, seed=13), rate=10.0)


_MISTAKES = {
    "taus not numbers": lambda: adavar.deviation(_noise(100), taus=["a"]),
    "taus complex": lambda: adavar.deviation(_noise(100), taus=[1j]),
    "davar taus not numbers": lambda: adavar.davar(_noise(100), window=30, taus=["a"]),
    "points_per_decade huge": lambda: adavar.deviation(
        _noise(100), taus="log", points_per_decade=10**12
    ),
    "points_per_decade above the bound": lambda: adavar.deviation(
        _noise(100), taus="log", points_per_decade=MAX_POINTS_PER_DECADE + 1
    ),
    "points_per_decade not whole": lambda: adavar.deviation(
        _noise(100), taus="log", points_per_decade=2.5
    ),
    "davar points_per_decade": lambda: adavar.davar(
        _noise(100), window=30, taus="log", points_per_decade=10**9
    ),
    "rate None": lambda: adavar.deviation(_noise(100), rate=None),
    "rate True": lambda: adavar.deviation(_noise(100), rate=True),
    "davar rate None": lambda: adavar.davar(_noise(100), window=30, rate=None),
    "davar rate True": lambda: adavar.davar(_noise(100), window=30, rate=True),
    "adaptive rate None": lambda: adavar.adaptive_davar(
        _noise(500), lmax=100, lmin=60, l=10, rate=None
    ),
    "confidence not a number": lambda: adavar.deviation(_noise(100), confidence="a"),
    "davar confidence not a number": lambda: adavar.davar(_noise(100), window=30, confidence="a"),
    "fit unknown term": lambda: adavar.fit_noise(_result(), terms=["X"]),
    "fit terms not a list": lambda: adavar.fit_noise(_result(), terms=5),
    "fit n_reweight negative": lambda: adavar.fit_noise(_result(), n_reweight=-1),
    "fit n_reweight above the bound": lambda: adavar.fit_noise(
        _result(), n_reweight=MAX_REWEIGHT + 1
    ),
    "fit n_reweight huge": lambda: adavar.fit_noise(_result(), n_reweight=10**9, method="wls"),
    "fit n_reweight None": lambda: adavar.fit_noise(_result(), n_reweight=None),
    "fit unknown method": lambda: adavar.fit_noise(_result(), method="magic"),
    "fit non-Allan stat": lambda: adavar.fit_noise(adavar.deviation(_noise(2000), stat="mdev")),
    "fit without edf": lambda: adavar.fit_noise(adavar.deviation(_noise(2000), confidence=None)),
    "fit unknown units": lambda: adavar.fit_noise(_result(), units="furlong"),
    "fit bad bandwidth": lambda: adavar.fit_noise(_result(), bandwidth=-1.0),
    "fit bad tau_range": lambda: adavar.fit_noise(_result(), tau_range=(5.0, 1.0)),
    "fit no tau": lambda: adavar.fit_noise(object()),
    "fit gls of a surface": lambda: adavar.fit_noise(
        adavar.davar(_noise(1000), window=300, taus="octave"), method="gls"
    ),
    "fit_avar tau not numbers": lambda: adavar.fit_avar(["a"], [1.0]),
    "fit_avar bad shapes": lambda: adavar.fit_avar([1.0, 2.0], [1.0, 2.0, 3.0]),
    "fit_avar gls": lambda: adavar.fit_avar([1.0, 2.0], [1.0, 0.5], method="gls"),
}


@pytest.mark.parametrize("name", sorted(_MISTAKES))
def test_every_user_mistake_is_a_one_line_input_error(name):
    with pytest.raises(AdavarInputError) as excinfo:
        _MISTAKES[name]()
    _one_line(excinfo)


def test_the_bounds_themselves_are_accepted():
    x = _noise(3000, seed=14)
    res = adavar.deviation(x, taus="log", points_per_decade=MAX_POINTS_PER_DECADE)
    assert res.m.size > 100
    adavar.fit_noise(_result(), n_reweight=MAX_REWEIGHT, method="wls")
    adavar.deviation(x, rate=1.0, tau0=2.0)  # the CLI passes rate=1 with tau0 (the default)


def test_a_chunked_source_keeps_its_reads_within_a_chunk():
    """The scale of a streamed record comes from its first 1024 samples (not all zeros)."""

    class Recording(stream.ArraySource):
        def __init__(self, array):
            super().__init__(array)
            self.reads = []

        def _read_raw(self, start, stop):
            self.reads.append(stop - start)
            return super()._read_raw(start, stop)

    x = np.concatenate([np.zeros(3000), np.ldexp(_noise(5000, seed=15), 1000)])
    src = Recording(x)
    got = adavar.deviation(src, chunk_size=1024)
    assert max(src.reads) <= 2048 and np.isfinite(got.dev).all()
    np.testing.assert_allclose(got.dev, adavar.deviation(x).dev, rtol=1e-14)
