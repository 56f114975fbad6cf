"""The per-record noise identification and interval tables against slow references.

:func:`adavar.stats.statistics.record_noise_types` takes the lag-1 statistics of the short
averaging factors from moments gathered while integrating (all fused levels at once, one
small kernel), computes R(n) for every B1 tau in one pass of each kernel and reuses the
OADEV being computed; :func:`adavar.stats.edf.interval_table` caches the EDF and chi-square
quantiles of a tau grid. Each is checked here against the plain, materialised computation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adavar import simulate
from adavar._kernels import differences as diff
from adavar.core.taus import averaging_factors
from adavar.stats import edf, record_sums
from adavar.stats import noise_id as nid
from adavar.stats import statistics as stats


def _series(kind: str, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n)
    f = np.fft.rfftfreq(n)
    f[0] = f[1]
    return {
        "white": w,
        "random_walk": np.cumsum(w),
        "random_run": np.cumsum(np.cumsum(w)) / n,
        "flicker": np.fft.irfft(np.fft.rfft(w) / np.sqrt(f), n),
        "white_pm": np.diff(rng.standard_normal(n + 1)),
        "offset": 1e6 + w,
        "drift": w + np.linspace(0.0, 30.0, n),
        "steep": 1e3 * np.arange(n) + w,
        "tiny": 1e-300 * w,
        "huge": 1e300 * w,
        "constant": np.full(n, 3.0),
        # a MEMS gyro at 200 Hz: 40 Hz bandwidth, quantised to 1/131 deg/s
        "gyro": simulate.sensor(
            n,
            rate=200.0,
            angle_random_walk=0.01,
            bias_instability=0.003,
            bandwidth=40.0,
            lsb=1 / 131,
            seed=seed,
        ),
    }[kind]


KINDS = [
    "white", "random_walk", "random_run", "flicker", "white_pm", "offset", "drift", "steep",
    "tiny", "huge", "constant", "gyro",
]  # fmt: skip


def _cluster_sums(u: np.ndarray, m: int) -> np.ndarray:
    return np.array([math.fsum(u[k * m : (k + 1) * m]) for k in range(u.size // m)])


def _lag1_reference(z: np.ndarray) -> tuple[float, float]:
    """r1 and its denominator of the least-squares-line residuals of ``z``, materialised."""
    t = np.linspace(-1.0, 1.0, z.size)
    x = z - np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyfit(t, z, 1))
    c = x - x.mean()
    den = float(np.dot(c, c))
    return float(np.dot(c[:-1], c[1:])) / den, den


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(8, 5000),
    seed=st.integers(0, 10**6),
    kind=st.sampled_from(KINDS),
)
def test_fused_levels_match_the_materialised_series(n, seed, kind):
    """The fused-level kernel's lag-1 statistics are those of the cluster sums themselves."""
    u, _ = stats.scaled(_series(kind, n, seed))
    p = diff.anchored_phase(u, cluster_stats=True)
    r1, den, counts, zmax, ok = diff.fused_lag1_levels(p)
    assert r1.size == den.size == counts.size == zmax.size == ok.size == diff.FUSED_LEVELS
    for level in range(diff.FUSED_LEVELS):
        m = 1 << level
        z = _cluster_sums(u - p.shift, m)
        assert counts[level] == n // m
        if n // m < 8:
            assert not ok[level] and np.isnan(r1[level])
            assert diff.fused_lag1(p, m) is None
            continue
        assert zmax[level] == pytest.approx(np.abs(z).max(), rel=1e-9)
        want_r1, want_den = _lag1_reference(z) if np.ptp(z) > 0 else (math.nan, 0.0)
        if not ok[level]:  # refused only where the trend (or nothing) dominates
            assert kind in ("steep", "constant") or not want_den > 2e-6 * np.dot(z, z)
            assert diff.fused_lag1(p, m) is None
            continue
        assert r1[level] == pytest.approx(want_r1, abs=1e-8)
        assert den[level] == pytest.approx(want_den, rel=1e-6)
        one = diff.fused_lag1(p, m)
        assert (one[0][0], one[1][0], one[2][0], one[3]) == (
            r1[level],
            den[level],
            counts[level],
            zmax[level],
        )


def _rn_reference(u: np.ndarray, m: int) -> float | None:
    """R(n) = MVAR / AVAR from the materialised phase (plain NumPy, O(N) per tau)."""
    x = np.concatenate([[0.0], np.cumsum(u - np.median(u))])
    d2 = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
    avar = np.mean(d2**2) / (2.0 * m * m)
    window = np.concatenate([[0.0], np.cumsum(d2)])
    mvar = np.mean((window[m:] - window[:-m]) ** 2) / (2.0 * m**4)
    return nid.rn_ratio(float(avar), float(mvar))


def _reference_noise_types(u, ms, dmax, noise_id):
    """The rule of :func:`record_noise_types` for rate data, one tau at a time, written out.

    ``"sp1065"``: lag-1 first on the materialised decimated phase (quadratic detrend; white
    PM there checked by R(n)), then, as ``"input"`` and ``"stable32"`` do from the start,
    on the materialised cluster means (:func:`adavar.stats.noise_id.identify_noise_lag1`, one
    difference fewer after the phase, FM types at the averaged rate's boundaries for
    m >= 2); else B1 with R(n) from the materialised phase, else the nearest identified
    tau.
    """
    strict = noise_id == "stable32"
    on_phase = noise_id == "sp1065"
    alpha = []
    for m in ms.tolist():
        z = _cluster_sums(u, m) / m
        a = math.nan
        try:
            if z.size >= nid.MIN_POINTS_LAG1 and on_phase:
                x = nid.detrend_poly(np.concatenate([[0.0], np.cumsum(z)]), 2)
                c = x - x.mean()
                den = float(np.dot(c, c))
                r1 = float(np.dot(c[:-1], c[1:])) / den if den > 0 else math.nan
                scale = float(np.max(np.abs(np.cumsum(z * m))))
                got = nid.phase_order0(r1, den, z.size + 1, scale * 1.0)
                if got == got:
                    a = nid.clamp_alpha(got, dmax)
                    rn = _rn_reference(u, m)
                    if a == 2 and m >= 4 and rn is not None:
                        white, flicker = nid.rn_theory_pm(m)
                        a = 1 if rn > math.sqrt(white * flicker) else 2
                else:
                    a = nid.identify_noise_lag1(
                        z, data_type="rate", dmax=dmax - 1, averaged=m >= 2
                    )[0]
            elif z.size >= nid.MIN_POINTS_LAG1:
                a = nid.identify_noise_lag1(z, data_type="rate", dmax=dmax)[0]
            elif z.size >= nid.MIN_POINTS_B1:
                a = nid.identify_noise_b1(z, data_type="rate", dmax=dmax)
                rn = _rn_reference(u, m)
                if a == 1 and rn is not None:
                    a = nid.identify_noise_b1(z, data_type="rate", dmax=dmax, rn_ratio=rn, m=m)
                elif a == 0 and m >= 4 and not strict and rn is not None:
                    white, flicker = nid.rn_theory_pm(m)
                    if rn < math.sqrt(white * flicker):
                        a = 2
                    elif rn < math.sqrt(flicker * nid.RN_WHITE_FM):
                        a = 1
            if a == a:
                a = nid.clamp_alpha(a, dmax)
        except nid.NoiseIdError:
            a = math.nan
        alpha.append(a)
    return nid.fill_unidentified(np.array(alpha, dtype=float))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(40, 4000),
    seed=st.integers(0, 10**6),
    kind=st.sampled_from(KINDS),
    taus=st.sampled_from(["octave", "all", "decade", "log"]),
    dmax=st.sampled_from([2, 3]),
    noise_id=st.sampled_from(["sp1065", "stable32", "input"]),
)
def test_record_noise_types_match_the_plain_rule(n, seed, kind, taus, dmax, noise_id):
    u, _ = stats.scaled(_series(kind, n, seed))  # as deviation() does
    ms, _ = averaging_factors(taus, (n - 1) // 3, 1.0)
    if taus == "all":
        ms = ms[:: max(1, ms.size // 40)]  # the reference is slow
    phase = diff.anchored_phase(u, cluster_stats=True)
    got = stats.record_noise_types(phase, ms, dmax, noise_id=noise_id)
    want = _reference_noise_types(u, ms, dmax, noise_id)
    np.testing.assert_array_equal(got[0], want[0])
    assert got[1] == want[1]
    # the OADEV passed in for R(n) changes nothing
    n_avar = phase.n_points - 2 * ms
    oavar = record_sums.overlapping_sums(phase, ms, 2) / (2.0 * ms.astype(float) ** 2 * n_avar)
    again = stats.record_noise_types(phase, ms, dmax, noise_id=noise_id, avar=oavar)
    np.testing.assert_array_equal(again[0], got[0])
    # without the fused moments (streaming kernels only) the answer is the same
    plain = stats.record_noise_types(diff.anchored_phase(u), ms, dmax, noise_id=noise_id)
    np.testing.assert_array_equal(plain[0], got[0])


@pytest.mark.parametrize("kind", ["white", "random_walk", "white_pm", "flicker", "offset"])
@pytest.mark.parametrize("noise_id", ["sp1065", "stable32"])
def test_phase_data_rn_batch_matches_one_tau_at_a_time(kind, noise_id):
    """Phase data: R(n) from the batched table equals the per-tau computation."""
    u = _series(kind, 3000, 4)
    ms, _ = averaging_factors("all", 999, 1.0)
    ms = ms[::7]
    phase = diff.anchored_phase(u, cluster_stats=True)
    table = stats._RnTable(phase, [m for m in ms.tolist() if 10 <= 3000 // m < 30])
    for m in ms.tolist():
        assert table(m) == stats._rn_in_memory(phase, [m])[m]
        want = _rn_reference(u, m)
        if want is not None:
            assert table(m) == pytest.approx(want, rel=1e-9)
    got = stats.record_noise_types(phase, ms, 2, data_type="phase", noise_id=noise_id)
    assert got[0].shape == ms.shape


@pytest.mark.parametrize("stat", ["oadev", "adev", "mdev", "tdev", "hdev", "ohdev", "totdev"])
@pytest.mark.parametrize("method", edf.TOTDEV_EDF_METHODS)
def test_interval_table_is_edf_and_chi2_interval(stat, method):
    ms = np.array([1, 2, 4, 8, 16, 64, 128, 300])
    alpha = (
        np.array([2, 1, 0, -1, -2, 0, 1, -2])
        if stat[-4:] != "hdev"
        else np.array([2, 1, 0, -1, -2, -3, -4, 0])
    )
    values, upper, lower = edf.interval_table(stat, alpha, ms, 1000, 0.9, totdev_edf=method)
    want = [edf.edf(stat, a, m, 1000, totdev_edf=method) for a, m in zip(alpha, ms, strict=True)]
    np.testing.assert_array_equal(values, want)
    var = np.linspace(0.5, 3.0, ms.size)
    low, high = edf.chi2_bounds(var, values, upper, lower)
    want_low, want_high = edf.chi2_interval(var, np.array(want), 0.9)
    np.testing.assert_array_equal(low, want_low)
    np.testing.assert_array_equal(high, want_high)
    assert not values.flags.writeable  # shared by every caller of the same grid
    assert edf.interval_table(stat, alpha, ms, 1000, 0.9, totdev_edf=method)[0] is values


def test_chi2_quantiles_are_scipy_chi2_ppf():
    from scipy.stats import chi2

    k = np.array([1.0, 2.5, 10.0, 333.3, 1e6])
    upper, lower = edf.chi2_quantiles(k, 0.683)
    np.testing.assert_allclose(upper, chi2.ppf(0.5 * 1.683, k), rtol=1e-13)
    np.testing.assert_allclose(lower, chi2.ppf(0.5 * 0.317, k), rtol=1e-13)


def test_deviation_result_owns_its_arrays():
    """The cached tau grid and EDF table are not the result's arrays."""
    x = np.random.default_rng(0).standard_normal(1000)
    first = stats.deviation(x)
    first.edf[:] = -1.0
    first.m[:] = 0
    second = stats.deviation(x)
    assert (second.edf > 0).all() and (second.m > 0).all()
    assert averaging_factors("octave", 499, 1.0)[0][0] == 1


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.floats(allow_nan=True, allow_infinity=False, width=64),
            st.integers(-(2**40), 2**40).map(float),
        ),
        min_size=1,
        max_size=1100,
    )
)
def test_median_is_numpy_median(values):
    a = np.array(values, dtype=np.float64)
    with np.errstate(over="ignore"):  # the middle pair of huge values overflows for both
        got, want = diff._median(a), float(np.median(a))
    assert got == want or (math.isnan(got) and math.isnan(want))


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(4, 60),
    seed=st.integers(0, 10**6),
    scale=st.sampled_from([1e-150, 1.0, 1e150]),
    offset=st.sampled_from([0.0, 1e8]),
    walk=st.booleans(),
)
def test_b1_alpha_is_the_numpy_ratio(n, seed, scale, offset, walk):
    """B1's sums are np.var(y, ddof=1) and np.mean(np.diff(y) ** 2), bit for bit."""
    y = np.random.default_rng(seed).standard_normal(n) * scale
    y = (np.cumsum(y) if walk else y) + offset * scale
    avar = 0.5 * float(np.mean(np.diff(y) ** 2))
    if not avar > 0:
        with pytest.raises(nid.NoiseIdError):
            nid.b1_alpha(y)
        return
    ratio = float(np.var(y, ddof=1)) / avar
    want = 1
    for a_hi, (mu_lo, mu_hi) in zip((0, -1, -2), ((-2, -1), (-1, 0), (0, 1)), strict=True):
        if ratio <= math.sqrt(nid.b1_theory(n, mu_lo) * nid.b1_theory(n, mu_hi)):
            break
        want = a_hi
    assert nid.b1_alpha(y) == want


def test_compiled_rules_are_the_python_rules():
    """The Numba twins (same source) give the Python functions' numbers exactly."""
    rng = np.random.default_rng(5)
    for _ in range(2000):
        dmax = int(rng.integers(0, 4))
        r1 = rng.uniform(-1.2, 1.0, dmax + 1)
        r1[rng.random(dmax + 1) < 0.1] = -1.0
        den = rng.uniform(0.0, 2.0, dmax + 1) * 10.0 ** rng.integers(-40, 3)
        sizes = rng.integers(1, 100, dmax + 1)
        scale = float(10.0 ** rng.integers(-30, 5))
        offset, dmin = int(rng.choice([0, 2])), int(rng.integers(0, dmax + 1))
        want = nid.lag1_decision(r1, den, sizes, scale, offset, dmin, dmax)
        got = nid._lag1_decision_compiled(r1, den, sizes, scale, offset, dmin, dmax)
        assert got[:2] == want[:2]
        assert got[2] == want[2] or (math.isnan(got[2]) and math.isnan(want[2]))
    for alpha in (-4, -3, -2, -1, 0, 1, 2, 3, 6):
        for dmax in (2, 3):
            assert nid._clamp_alpha_compiled(alpha, dmax) == nid.clamp_alpha(alpha, dmax)
    for m in [1, 2, 3, 17, 1000, 55_109, 10**6, 9 * 10**7]:  # 55_109**4 overflows int64
        for terms in (1, 7, 10**6):
            total = float(rng.uniform(0.1, 10.0)) * 10.0 ** int(rng.integers(-20, 20))
            want = total / (2.0 * m**4 * terms)  # the exact integer m**4, rounded once
            assert nid.mvar_of_sum(total, m, terms) == want


# --- the decimated phase's lag-1 test: sequential passes, and the fused levels (issue 42)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(40, 20_000), seed=st.integers(0, 10**6), kind=st.sampled_from(KINDS))
def test_decimated_phase_stats_are_the_two_passes(n, seed, kind):
    """Over the anchored phase, without the cluster sums materialised: the same bits."""
    from adavar._kernels.decimated_phase import decimated_phase_stats

    u, _ = stats.scaled(_series(kind, n, seed))
    p = diff.anchored_phase(u, cluster_stats=True)
    for m in (1, 2, 3, 8, 33, n // 40 + 1):
        count = n // m
        z = diff.cluster_differences(p.r, p.hh, p.hl, m, count)
        r1, den, _, scale = nid.decimated_phase_lag1(z)
        got = decimated_phase_stats(p.r, p.hh, p.hl, m, count)
        assert np.array_equal([r1, den, scale], got, equal_nan=True), (m, got)


def _fused_rows(u: np.ndarray):
    from adavar._kernels.decimated_phase import decimated_phase_stats, fused_phase_levels

    p = diff.anchored_phase(u, cluster_stats=True)
    n = u.size
    for level, row in enumerate(fused_phase_levels(p).tolist()):
        count = n >> level
        if count >= 8:
            yield row, decimated_phase_stats(p.r, p.hh, p.hl, 1 << level, count), count


def _check_bounds(u: np.ndarray) -> int:
    """The fused levels' statistics against the sequential passes' within their bounds;
    the number of levels bounded."""
    bounded = 0
    for (r1, den, scale, tol_r1, tol_den), (r1_s, den_s, scale_s), _ in _fused_rows(u):
        assert scale_s <= scale or not den > 0
        if not (tol_r1 < 0.5 and tol_den < 0.5):
            continue
        bounded += 1
        assert abs(r1 - r1_s) <= tol_r1
        assert abs(den - den_s) <= tol_den * den
    return bounded


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(8, 60_000),
    seed=st.integers(0, 10**6),
    kind=st.sampled_from(KINDS),
    data=st.sampled_from(["rate", "phase"]),
)
def test_fused_phase_levels_are_within_their_bounds(n, seed, kind, data):
    """From the integration's block moments, the decimated phase's r1, den and scale
    lie within the bounds returned of those of the two sequential passes."""
    x, _ = stats.scaled(_series(kind, n, seed))
    _check_bounds(x if data == "rate" else np.diff(x))


def test_fused_phase_bounds_settle_noise():
    """On noise of 1e6 samples the bounds settle the decision at every level, and they
    hold: white and random-walk FM to 1e-6 against the 0.67 the decision needs; white PM
    (as phase data) to 0.1 against 0.33: the trend its phase has about the integration's
    shift widens the sequential passes' bound."""
    rng = np.random.default_rng(11)
    w = rng.standard_normal(1 << 20)
    for u, widest in ((w, 1e-6), (np.cumsum(w) * 1e-3, 1e-6), (np.diff(w), 0.1)):
        assert _check_bounds(u) == diff.FUSED_LEVELS
        for row, _, count in _fused_rows(u):
            assert row[3] < widest
            assert nid.phase_order0_settled(*row[:2], count + 1, *row[2:]) >= 0


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("data", ["rate", "phase"])
def test_fused_phase_decisions_are_the_sequential_ones(monkeypatch, kind, data):
    """The noise types with the fused levels' shortcut and without (the sequential
    passes at every tau): the same, record after record."""
    for n, seed in ((300, 1), (5000, 2), (70_000, 3)):
        x, _ = stats.scaled(_series(kind, n, seed))
        u = x if data == "rate" else np.diff(x)
        phase = diff.anchored_phase(u, cluster_stats=True)
        ms, _ = averaging_factors("octave", (n - 1) // 3, 1.0)
        ms = np.unique(np.concatenate([ms, [3, 5, 6]]))
        for dmax in (2, 3):
            got = stats.record_noise_types(phase, ms, dmax, data_type=data)
            with monkeypatch.context() as m:
                m.setattr(nid, "fused_phase_levels", lambda p: None)
                want = stats.record_noise_types(phase, ms, dmax, data_type=data)
            np.testing.assert_array_equal(got[0], want[0])
