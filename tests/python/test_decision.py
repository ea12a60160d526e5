"""Three-way equivalence / difference verdicts and their power calculations."""

import numpy as np
import pytest
from scipy import stats

from compare.decision import (equivalence_power, minimum_detectable_difference, sample_size_for_equivalence,
                              verdict_independent, verdict_paired)


def _standardized(rng, n):
    z = rng.normal(size=n)
    return (z - z.mean()) / z.std(ddof=1)


def test_identical_large_samples_are_equivalent():
    rng = np.random.default_rng(11)
    a, b = rng.normal(0, 1, 50), rng.normal(0, 1, 50)
    r = verdict_independent(a, b, margin=1.0)
    assert r["verdict"] == "equivalent"
    assert -1 < r["ci90"][0] < r["ci90"][1] < 1
    assert r["ci95"][0] < r["ci90"][0] and r["ci90"][1] < r["ci95"][1]
    assert r["tost_p"] < 0.05
    assert r["reason"].startswith("90 % interval [") and "inside \u00b11" in r["reason"]
    assert (r["n_a"], r["n_b"], r["margin"]) == (50, 50, 1.0)


def test_shifted_means_are_different():
    rng = np.random.default_rng(12)
    r = verdict_independent(rng.normal(0, 1, 10), rng.normal(5, 1, 10), margin=1.0)
    assert r["verdict"] == "different"
    assert r["ci95"][0] > 0 and r["ci95"][1] > 1
    assert r["tost_p"] > 0.5
    assert r["reason"].startswith("95 % interval [") and "excludes 0 and reaches beyond \u00b11" in r["reason"]


def test_few_noisy_runs_are_inconclusive():
    rng = np.random.default_rng(13)
    r = verdict_independent(rng.normal(0, 10, 3), rng.normal(0, 10, 3), margin=0.5)
    assert r["verdict"] == "inconclusive"
    assert r["ci95"][0] < 0 < r["ci95"][1]
    assert "90 % interval [" in r["reason"] and "not inside \u00b10.5" in r["reason"]
    assert r["reason"].endswith("95 % interval contains 0")


def test_equivalent_takes_precedence_when_the_wider_interval_crosses_the_margin():
    # mean 0.6, se 0.191, n = 10: 90 % [0.25, 0.95], 95 % [0.17, 1.03].
    rng = np.random.default_rng(15)
    d = 0.6 + 0.191 * np.sqrt(10) * _standardized(rng, 10)
    r = verdict_paired(np.zeros(10), d, margin=1.0)
    lo95, hi95 = r["ci95"]
    assert lo95 > 0 and max(abs(lo95), abs(hi95)) > 1  # the "different" condition holds as well
    assert -1 < r["ci90"][0] and r["ci90"][1] < 1
    assert r["verdict"] == "equivalent"


def test_pairing_removes_shared_spread():
    rng = np.random.default_rng(16)
    a = rng.normal(0, 100, 10)
    b = a + 0.1 + rng.normal(0, 0.01, 10)
    rp = verdict_paired(a, b, margin=1.0)
    ri = verdict_independent(a, b, margin=1.0)
    assert rp["verdict"] == "equivalent"
    assert rp["difference"] == pytest.approx(0.1, abs=0.02)
    assert rp["mdd"] < 0.1
    assert ri["verdict"] == "inconclusive"
    assert ri["ci90"][0] < -1 and ri["ci90"][1] > 1
    assert ri["difference"] == pytest.approx(rp["difference"])


@pytest.mark.parametrize("verdict", [verdict_independent, verdict_paired])
def test_difference_is_b_minus_a(verdict):
    rng = np.random.default_rng(17)
    a = rng.normal(0, 1, 8)
    b = a + 3 + rng.normal(0, 0.5, 8)
    r = verdict(a, b, margin=1.0)
    assert r["difference"] == pytest.approx(b.mean() - a.mean())
    assert r["difference"] > 2
    assert 0 < r["ci95"][0] < r["difference"] < r["ci95"][1]
    assert r["verdict"] == "different"
    swapped = verdict(b, a, margin=1.0)
    assert swapped["difference"] == pytest.approx(-r["difference"])
    assert swapped["ci95"] == pytest.approx([-r["ci95"][1], -r["ci95"][0]])


def test_tost_p_agrees_with_the_90_percent_interval():
    rng = np.random.default_rng(18)
    for _ in range(200):
        a, b = rng.normal(0, 1, 6), rng.normal(rng.uniform(-1, 1), rng.uniform(0.3, 2), 9)
        for r in (verdict_independent(a, b, 1.0), verdict_paired(a[:6], b[:6], 1.0)):
            assert (r["tost_p"] < 0.05) == (r["verdict"] == "equivalent")


def test_zero_spread():
    a = np.full(4, 2.0)
    r = verdict_independent(a, np.full(5, 2.5), margin=1.0)
    assert r["verdict"] == "equivalent" and r["ci90"] == [0.5, 0.5] and r["ci95"] == [0.5, 0.5]
    assert r["mdd"] == 0.0
    assert verdict_independent(a, np.full(5, 3.0), margin=1.0)["verdict"] == "equivalent"  # |d| == margin
    r = verdict_independent(a, np.full(5, 0.5), margin=1.0)
    assert r["verdict"] == "different" and r["difference"] == -1.5
    # paired: spread in a, none in the differences
    a = np.array([1.0, 5.0, -3.0, 2.0])
    assert verdict_paired(a, a + 0.25, margin=0.5)["verdict"] == "equivalent"
    r = verdict_paired(a, a - 2.0, margin=0.5)
    assert r["verdict"] == "different" and "excludes 0" in r["reason"]


def test_too_few_runs():
    r = verdict_independent([1.0], [1.0, 2.0, 3.0], margin=1.0)
    assert r["verdict"] == "inconclusive" and r["reason"] == "too few runs"
    assert r["ci90"] is None and r["difference"] == pytest.approx(1.0) and r["n_a"] == 1
    r = verdict_paired([1.0], [5.0], margin=1.0)
    assert r["verdict"] == "inconclusive" and r["reason"] == "too few runs"
    with pytest.raises(ValueError):
        verdict_paired([1.0, 2.0], [1.0, 2.0, 3.0], margin=1.0)
    with pytest.raises(ValueError):
        verdict_independent([1.0, 2.0], [1.0, 2.0], margin=0.0)


def test_minimum_detectable_difference():
    z = stats.norm.ppf(0.975) + stats.norm.ppf(0.8)
    assert minimum_detectable_difference(2.0, 200) == pytest.approx(z * 2.0 * np.sqrt(2 / 200), rel=0.02)
    assert minimum_detectable_difference(2.0, 200, paired=True) == pytest.approx(z * 2.0 / np.sqrt(200), rel=0.02)
    for paired in (False, True):
        m100 = minimum_detectable_difference(1.0, 100, paired=paired)
        assert minimum_detectable_difference(1.0, 400, paired=paired) / m100 == pytest.approx(0.5, rel=0.02)
    # small samples: the t distribution makes it larger than the normal value
    assert minimum_detectable_difference(1.0, 5) > 1.1 * z * np.sqrt(2 / 5)
    assert minimum_detectable_difference(1.0, 5) == pytest.approx(2.024, abs=0.002)  # tabulated d, n = 5 per group
    # unequal sizes lie between the equal-size values
    m = minimum_detectable_difference(1.0, 10, 40)
    assert minimum_detectable_difference(1.0, 40) < m < minimum_detectable_difference(1.0, 10)


def _monte_carlo(true_diff, n, paired, reps=4000, seed=0):
    rng = np.random.default_rng(seed)
    hits = 0
    for _ in range(reps):
        a = rng.normal(0, 1, n)
        if paired:
            r = verdict_paired(a, a + rng.normal(true_diff, 1, n), 1.0)
        else:
            r = verdict_independent(a, rng.normal(true_diff, 1, n), 1.0)
        hits += r["verdict"] == "equivalent"
    return hits / reps


@pytest.mark.parametrize("paired,n", [(False, 14), (True, 8)])
@pytest.mark.parametrize("true_diff", [0.0, 0.5])
def test_equivalence_power_matches_monte_carlo(true_diff, paired, n):
    exact = equivalence_power(true_diff, 1.0, n, 1.0, paired=paired)
    assert 0.1 < exact < 0.9
    assert _monte_carlo(true_diff, n, paired, seed=int(10 * true_diff) + paired) == pytest.approx(exact, abs=0.03)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_equivalence_power_and_the_noncentral_t_bound():
    for paired, n in ((True, 4), (True, 30), (False, 6), (False, 40)):
        df = n - 1 if paired else 2 * n - 2
        se = 1 / np.sqrt(n) if paired else np.sqrt(2 / n)
        tc = stats.t.ppf(0.95, df)
        bound = stats.nct.sf(tc, df, 1.0 / se) + stats.nct.cdf(-tc, df, -1.0 / se) - 1
        p = equivalence_power(0.0, 1.0, n, 1.0, paired=paired)
        assert p >= bound - 1e-9
        if n >= 30:  # the interval is then almost never wider than 2 margin
            assert p == pytest.approx(bound, abs=1e-4)
    assert equivalence_power(0.0, 1.0, 1, 1.0, paired=True) == 0.0
    assert equivalence_power(1.5, 1.0, 1000, 1.0) < 1e-6


@pytest.mark.parametrize("paired", [False, True])
@pytest.mark.parametrize("true_diff", [0.0, 0.3])
def test_sample_size_for_equivalence(paired, true_diff):
    n = sample_size_for_equivalence(1.0, 1.0, true_diff=true_diff, paired=paired)
    assert n is not None
    assert equivalence_power(true_diff, 1.0, n, 1.0, paired=paired) >= 0.8
    assert equivalence_power(true_diff, 1.0, n - 1, 1.0, paired=paired) < 0.8
    assert sample_size_for_equivalence(1.0, 1.0, true_diff=true_diff, paired=paired, n_max=n - 1) is None


def test_sample_size_known_values():
    assert sample_size_for_equivalence(1.0, 1.0) == 18
    assert sample_size_for_equivalence(1.0, 1.0, paired=True) == 11
    assert sample_size_for_equivalence(1.0, 1.0, true_diff=1.0) is None


# ---------------------------------------------------------------- yes/no observables

from compare.decision import proportion_mdd, proportion_power, threshold_test, verdict_proportions  # noqa: E402


def test_proportions_equal_and_certain_are_equivalent():
    r = verdict_proportions(10, 10, 10, 10, margin=0.3)
    assert r["verdict"] == "equivalent"
    assert r["ci90"][0] > -0.3 and r["ci90"][1] < 0.3
    assert r["difference"] == 0.0


def test_proportions_opposite_are_different():
    r = verdict_proportions(0, 10, 10, 10, margin=0.3)
    assert r["verdict"] == "different"
    assert r["ci95"][0] > 0.3
    assert r["difference"] == 1.0  # b - a


def test_proportions_with_few_runs_are_inconclusive():
    # 5 packings each: even 5 of 5 against 5 of 5 cannot bound the difference within 0.3
    assert verdict_proportions(5, 5, 5, 5, margin=0.3)["verdict"] == "inconclusive"
    assert verdict_proportions(9, 10, 10, 10, margin=0.3)["verdict"] == "inconclusive"


def test_proportion_power_matches_monte_carlo():
    rng = np.random.default_rng(5)
    p, n, margin = 0.9, 20, 0.3
    exact = proportion_power(p, p, n, n, margin)
    ka, kb = rng.binomial(n, p, 4000), rng.binomial(n, p, 4000)
    mc = np.mean([verdict_proportions(a, n, b, n, margin, with_mdd=False)["verdict"] == "equivalent"
                  for a, b in zip(ka, kb)])
    assert abs(exact - mc) < 0.03
    assert proportion_power(1.0, 1.0, 8, 8, margin) == pytest.approx(1.0)
    assert proportion_power(1.0, 1.0, 5, 5, margin) == 0.0  # 5 of 5 each is inconclusive


def test_proportion_mdd_shrinks_with_runs():
    small, large = proportion_mdd(0.5, 10, 10, 0.3), proportion_mdd(0.5, 40, 40, 0.3)
    assert large < small
    # the shift found is called different with probability >= 0.8, a shift 0.05 smaller is not
    assert proportion_power(0.5, 0.5 + large, 40, 40, 0.3, outcome="different") >= 0.8 or \
        proportion_power(0.5, 0.5 - large, 40, 40, 0.3, outcome="different") >= 0.8
    assert proportion_power(0.5, 0.5 + large - 0.05, 40, 40, 0.3, outcome="different") < 0.8


def test_threshold_test():
    assert threshold_test(10, 10, 0, 10)["present"]
    assert threshold_test(10, 10, 0, 10)["p"] == pytest.approx(1 / 184756)  # 1 / C(20, 10)
    assert not threshold_test(3, 6, 1, 6)["present"]
    assert not threshold_test(0, 10, 10, 10)["present"]  # one-sided: rising below, not above, is no threshold


def test_threshold_power_is_exact():
    from scipy import stats as st

    from compare.decision import threshold_power
    # 4 of 4 against 0 of 4: p = 1 / C(8, 4) = 0.014, shown; 3 of 3 against
    # 0 of 3: p = 1 / C(6, 3) = 0.05, not below 0.05
    assert threshold_power(1.0, 4, 0.0, 4) == pytest.approx(1.0)
    assert threshold_power(1.0, 3, 0.0, 3) == pytest.approx(0.0)
    # eight runs a side and none rising below: the test needs 4 of 8 above
    # (C(8, 4) / C(16, 4) = 0.038; 3 of 8 gives 0.1), so the power is
    # P(Binomial(8, p) >= 4)
    assert threshold_power(0.45, 8, 0.0, 8) == pytest.approx(st.binom.sf(3, 8, 0.45))
    # rising as often below as above: shown only by chance, at most alpha
    assert threshold_power(0.5, 20, 0.5, 20) < 0.05
