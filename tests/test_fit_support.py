"""How sure the fit's choice of terms is: ``NoiseFit.term_support`` and the uncertainty with
the doubt of the choice in it (``fit_noise(uncertainty="averaged")``, the default).

The records come from ``tests/independent_noise.py`` (no adavar code). One hour of white
noise + rate random walk at 100 Hz does not tell a rate random walk from bias instability,
a ramp or quantization: in some seeds the selection takes a term the record has not, and
its conditional 1-sigma puts it 3-10 sigma from 0. The long version of these checks is
``benchmarks/bench_validation.py --part selection``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import adavar
from adavar.core.errors import AdavarInputError
from adavar.core.results import SUPPORT_WARNING
from adavar.core.terms import AVAR_FACTORS, TERM_NAMES
from adavar.fit.gls_select import Choice, selection_sigma, term_support
from tests.independent_noise import record

LETTER = dict(zip(TERM_NAMES, "QNBKR", strict=True))


def _choice(cols, criterion):
    coef = np.zeros(6)
    coef[list(cols)] = 1.0
    return Choice(tuple(cols), None, criterion, coef)


def test_term_support_is_the_summed_akaike_weight_of_the_models_holding_the_term():
    rivals = [_choice((1, 3), 10.0), _choice((1, 2), 11.0), _choice((1,), 14.0)]
    w = np.exp(-0.5 * np.array([0.0, 1.0, 4.0]))
    w /= w.sum()
    got = term_support(rivals)
    assert got[0] == 0.0 and got[4] == 0.0
    assert got[1] == pytest.approx(1.0, rel=1e-15)
    assert got[2] == pytest.approx(w[1], rel=1e-14)
    assert got[3] == pytest.approx(w[0], rel=1e-14)
    # one model judged (or none): nothing to weigh
    assert np.all(np.isnan(term_support(rivals[:1])))


@pytest.mark.parametrize("k", range(5))
def test_selection_sigma_adds_the_models_without_the_term_in_the_value_scale(k):
    c, sigma, support = 4.0e-6, 3.0e-7, 0.6
    v = math.sqrt(c / AVAR_FACTORS[k])
    s_v = sigma / (2.0 * math.sqrt(AVAR_FACTORS[k] * c))  # NoiseTerm's first-order rule
    want_v = math.sqrt(s_v**2 + (1.0 - support) * v**2)
    got = selection_sigma(c, sigma, support, AVAR_FACTORS[k])
    assert got / (2.0 * math.sqrt(AVAR_FACTORS[k] * c)) == pytest.approx(want_v, rel=1e-13)
    # a term every model holds, one not in the model, no weights: unchanged
    assert selection_sigma(c, sigma, 1.0, AVAR_FACTORS[k]) == pytest.approx(sigma, rel=1e-15)
    assert selection_sigma(0.0, sigma, 0.3, AVAR_FACTORS[k]) == sigma
    assert selection_sigma(c, sigma, math.nan, AVAR_FACTORS[k]) == sigma


@pytest.fixture(scope="module")
def chosen_wrongly():
    """Seeds of one hour at 100 Hz where the selection takes terms the record has not."""
    out = []
    for seed in (12, 15, 16):
        x, truth = record("white+RRW", 3600, 100.0, seed)
        dev = adavar.deviation(x, rate=100.0)
        out.append((truth, adavar.fit_noise(dev), adavar.fit_noise(dev, uncertainty="conditional")))
    return out


def test_a_term_the_record_has_not_is_warned_of_and_its_uncertainty_reaches_zero(chosen_wrongly):
    spurious = 0
    for truth, fit, conditional in chosen_wrongly:
        assert fit.uncertainty_rule == "averaged" and conditional.uncertainty_rule == "conditional"
        np.testing.assert_array_equal(fit.coefficients, conditional.coefficients)
        np.testing.assert_array_equal(fit.term_support, conditional.term_support)
        for k, name in enumerate(TERM_NAMES):
            term, given = fit.term(name), conditional.term(name)
            if not term.value > 0 or getattr(truth, LETTER[name]) > 0:
                continue
            spurious += 1
            support = fit.term_support[k]
            assert support < SUPPORT_WARNING
            assert given.value / given.uncertainty > 3.0  # the conditional 1-sigma: far from 0
            assert term.value / term.uncertainty < 2.0  # with the doubt of the choice
            assert term.uncertainty == pytest.approx(
                math.hypot(given.uncertainty, math.sqrt(1.0 - support) * term.value), rel=1e-9
            )
            assert any(w.startswith(f"{name} is in the model, but models without it carry")
                       for w in fit.warnings)  # fmt: skip
        # white noise: every model holds it, its uncertainty is the conditional one
        assert fit.term_support[1] == 1.0
        assert fit.angle_random_walk.uncertainty == conditional.angle_random_walk.uncertainty
    assert spurious >= 3


def test_conditional_uncertainty_is_the_fisher_one_of_the_model_chosen(chosen_wrongly):
    _, _, fit = chosen_wrongly[0]
    active = np.flatnonzero(fit.coefficients > 0)
    np.testing.assert_array_equal(
        fit.coefficient_uncertainty[active],
        np.sqrt(np.diag(fit.coefficient_covariance)[active]),
    )


def test_terms_the_curve_needs_keep_their_uncertainty_and_no_warning():
    x, _ = record(dict(N=1e-3, K=1e-4), 3600, 100.0, 3)
    dev = adavar.deviation(x, rate=100.0)
    fit, given = adavar.fit_noise(dev), adavar.fit_noise(dev, uncertainty="conditional")
    for k in (1, 3):
        assert fit.term_support[k] > 0.999
        assert fit.coefficient_uncertainty[k] == pytest.approx(
            given.coefficient_uncertainty[k], rel=1e-3
        )
    assert not any("models without it carry" in w for w in fit.warnings)


def test_other_selections_have_no_support_and_a_bad_rule_is_an_error():
    x, _ = record("white", 600, 100.0, 1)
    dev = adavar.deviation(x, rate=100.0)
    assert adavar.fit_noise(dev, select="significance").term_support is None
    assert adavar.fit_noise(dev, method="wls").term_support is None
    with pytest.raises(AdavarInputError, match="unknown uncertainty 'bayes'"):
        adavar.fit_noise(dev, uncertainty="bayes")
