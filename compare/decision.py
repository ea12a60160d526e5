"""Three-way verdicts for comparing two engines on a scalar observable.

Each engine is run over several seeds or packings; the observable gives one
value per run. With a margin fixed in advance, a comparison ends in

* ``equivalent``: the (1 - 2 alpha) confidence interval of the difference of
  means (90 % at alpha = 0.05) lies entirely inside (-margin, +margin); this is
  the two one-sided tests procedure (TOST), each test at level alpha;
* ``different``: the (1 - alpha) two-sided interval (95 %) excludes zero and
  its far end lies beyond the margin, max(|lo|, |hi|) > margin;
* ``inconclusive``: neither.

The difference is always mean(b) - mean(a). Statistics come from statsmodels
(Welch intervals for independent samples, one-sample t on b_i - a_i for
paired ones); the power calculations use scipy.
"""

import functools
import warnings

import numpy as np
from scipy import integrate, stats
from statsmodels.stats.power import TTestIndPower, TTestPower
from statsmodels.stats.proportion import confint_proportions_2indep
from statsmodels.stats.weightstats import CompareMeans, DescrStatsW, ttost_ind, ttost_paired


def _interval(ci):
    return f"[{ci[0]:.3g}, {ci[1]:.3g}]"


def _decide(diff, ci90, ci95, tost_p, margin, alpha, n_a, n_b, mdd):
    lo90, hi90 = ci90
    lo95, hi95 = ci95
    m = f"\u00b1{margin:g}"
    l90, l95 = f"{100 * (1 - 2 * alpha):g} %", f"{100 * (1 - alpha):g} %"
    # TOST rejects both one-sided nulls iff the interval is strictly inside; a
    # zero-spread point difference counts as equivalent on the margin itself.
    equivalent = -margin <= lo90 and hi90 <= margin if lo90 == hi90 else -margin < lo90 and hi90 < margin
    excludes_zero = lo95 > 0 or hi95 < 0
    different = excludes_zero and max(abs(lo95), abs(hi95)) > margin
    # Both can hold: the (1 - 2 alpha) interval lies within the (1 - alpha) one
    # but is narrower, so it may sit inside +-margin while the wider interval,
    # entirely on one side of zero, crosses the margin (e.g. 90 % [0.25, 0.95],
    # 95 % [0.18, 1.02], margin 1). TOST then has established equivalence at
    # its own level, and the crossing is only the extra width of the wider
    # interval, so equivalent takes precedence.
    if equivalent:
        verdict, reason = "equivalent", f"{l90} interval {_interval(ci90)} inside {m}"
    elif different:
        verdict, reason = "different", f"{l95} interval {_interval(ci95)} excludes 0 and reaches beyond {m}"
    else:
        verdict = "inconclusive"
        tail = "contains 0" if not excludes_zero else f"{_interval(ci95)} stays within {m}"
        reason = f"{l90} interval {_interval(ci90)} not inside {m}; {l95} interval {tail}"
    return {"verdict": verdict, "difference": float(diff), "ci90": [float(lo90), float(hi90)],
            "ci95": [float(lo95), float(hi95)], "tost_p": None if tost_p is None else float(tost_p),
            "margin": float(margin),
            "n_a": n_a, "n_b": n_b, "mdd": mdd, "reason": reason}


def _too_few(a, b, margin):
    diff = float(b.mean() - a.mean()) if a.size and b.size else None
    return {"verdict": "inconclusive", "difference": diff, "ci90": None, "ci95": None, "tost_p": None,
            "margin": float(margin), "n_a": int(a.size), "n_b": int(b.size), "mdd": None,
            "reason": "too few runs"}


def _check(a, b, margin):
    a, b = np.asarray(a, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("samples must be finite")
    if not margin > 0:
        raise ValueError("margin must be positive")
    return a, b


def _degenerate(diff, margin, alpha, n_a, n_b):
    """Zero spread: the interval collapses to the point difference."""
    eq = abs(diff) <= margin
    return _decide(diff, (diff, diff), (diff, diff), 0.0 if eq else 1.0, margin, alpha, n_a, n_b, 0.0)


def verdict_independent(a, b, margin, alpha=0.05):
    """Verdict for two independent samples (Welch: unequal variances).

    difference = mean(b) - mean(a). ``ci90`` is the (1 - 2 alpha) Welch interval
    (90 % at alpha = 0.05), ``ci95`` the (1 - alpha) one; ``tost_p`` is the larger
    of the two one-sided p-values of TOST against (-margin, +margin); ``mdd`` is
    the minimum detectable difference (alpha, power 0.8) for the pooled sd.
    Returns a dict with keys verdict, difference, ci90, ci95, tost_p, margin,
    n_a, n_b, mdd, reason.
    """
    a, b = _check(a, b, margin)
    n_a, n_b = int(a.size), int(b.size)
    if n_a < 2 or n_b < 2:
        return _too_few(a, b, margin)
    diff = b.mean() - a.mean()
    if np.ptp(a) == 0 and np.ptp(b) == 0:
        return _degenerate(diff, margin, alpha, n_a, n_b)
    # statsmodels: CompareMeans(d1, d2) and ttost_ind(x1, x2) refer to x1 - x2.
    cm = CompareMeans.from_data(b, a)
    ci90 = cm.tconfint_diff(alpha=2 * alpha, usevar="unequal")
    ci95 = cm.tconfint_diff(alpha=alpha, usevar="unequal")
    tost_p = ttost_ind(b, a, -margin, margin, usevar="unequal")[0]
    sd = np.sqrt(((n_a - 1) * a.var(ddof=1) + (n_b - 1) * b.var(ddof=1)) / (n_a + n_b - 2))
    mdd = minimum_detectable_difference(sd, n_a, n_b, alpha=alpha)
    return _decide(diff, ci90, ci95, tost_p, margin, alpha, n_a, n_b, mdd)


def verdict_paired(a, b, margin, alpha=0.05):
    """Verdict for paired samples (run i of both engines from the same packing).

    Uses d_i = b_i - a_i and a one-sample t interval, so difference =
    mean(b) - mean(a) = mean(d); variation shared by a pair cancels. Same
    returned dict as :func:`verdict_independent`; ``mdd`` uses the sd of d.
    """
    a, b = _check(a, b, margin)
    if a.size != b.size:
        raise ValueError("paired samples must have the same length")
    n = int(a.size)
    if n < 2:
        return _too_few(a, b, margin)
    d = b - a
    diff = d.mean()
    if np.ptp(d) == 0:
        return _degenerate(diff, margin, alpha, n, n)
    ds = DescrStatsW(d)
    ci90 = ds.tconfint_mean(alpha=2 * alpha)
    ci95 = ds.tconfint_mean(alpha=alpha)
    tost_p = ttost_paired(b, a, -margin, margin)[0]  # tests b - a
    mdd = minimum_detectable_difference(d.std(ddof=1), n, alpha=alpha, paired=True)
    return _decide(diff, ci90, ci95, tost_p, margin, alpha, n, n, mdd)


def minimum_detectable_difference(sd, n_a, n_b=None, alpha=0.05, power=0.8, paired=False):
    """Smallest true difference a two-sided t-test at ``alpha`` detects with ``power``.

    Independent samples with common standard deviation ``sd`` (``n_b``
    defaults to ``n_a``), or paired samples with ``sd`` of the differences and
    ``n_a`` pairs. The effect size in units of sd comes from
    statsmodels.stats.power (noncentral t), then is multiplied by sd.
    """
    n_b = n_a if n_b is None else n_b
    if sd == 0:
        return 0.0
    return _effect_size(int(n_a), int(n_b), float(alpha), float(power), bool(paired)) * float(sd)


@functools.lru_cache(maxsize=1024)
def _effect_size(n_a, n_b, alpha, power, paired):
    """Detectable effect in units of sd (cached: the root finding is slow)."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        if paired:
            es = TTestPower().solve_power(effect_size=None, nobs=n_a, alpha=alpha, power=power,
                                          alternative="two-sided")
        else:
            es = TTestIndPower().solve_power(effect_size=None, nobs1=n_a, ratio=n_b / n_a, alpha=alpha,
                                             power=power, alternative="two-sided")
    return float(np.ravel(es)[0])


def equivalence_power(true_diff, sd, n, margin, alpha=0.05, paired=False, n_b=None):
    """Probability that TOST at ``alpha`` declares equivalence within +-margin.

    Model: paired, n differences ~ N(true_diff, sd^2), df = n - 1,
    se = sd / sqrt(n); independent, n and n_b (default n) values per engine
    with common sd, se = sd sqrt(1/n + 1/n_b) and the pooled df = n + n_b - 2
    (an approximation to the Welch test). With the estimated standard error
    S = se * W, W^2 ~ chi2(df) / df, the two TOST statistics are
    T1 = (D + margin) / S and T2 = (D - margin) / S, each noncentral t with
    df and noncentrality (true_diff +- margin) / se, but dependent through S.
    Power = P(T1 > t_c and T2 < -t_c), t_c = t_{1-alpha, df}, evaluated
    exactly by conditioning on W (Owen's formula):

        power = int P(B + t_c w < Z < A - t_c w) f_W(w) dw,
        A = (margin - true_diff) / se, B = (-margin - true_diff) / se,

    over w < (A - B) / (2 t_c). The marginal noncentral t probabilities only
    give the lower bound nct.sf(t_c, df, nc1) + nct.cdf(-t_c, df, nc2) - 1.
    """
    n_b = n if n_b is None else n_b
    if paired:
        df, se = n - 1, sd / np.sqrt(n)
    else:
        df, se = n + n_b - 2, sd * np.sqrt(1.0 / n + 1.0 / n_b)
    if df < 1:
        return 0.0
    if sd == 0:
        return 1.0 if abs(true_diff) <= margin else 0.0
    tc = stats.t.ppf(1 - alpha, df)
    A, B = (margin - true_diff) / se, (-margin - true_diff) / se
    c_max = df * ((A - B) / (2 * tc)) ** 2  # chi2 value at which the interval width reaches 2 margin
    lo, hi = stats.chi2.ppf(1e-13, df), min(c_max, stats.chi2.ppf(1 - 1e-13, df))
    if hi <= lo:
        return 0.0

    def integrand(c):
        w = np.sqrt(c / df)
        return stats.chi2.pdf(c, df) * max(0.0, stats.norm.cdf(A - tc * w) - stats.norm.cdf(B + tc * w))

    val, _ = integrate.quad(integrand, lo, hi, limit=200, epsabs=1e-10)
    return float(min(1.0, max(0.0, val)))


def sample_size_for_equivalence(sd, margin, true_diff=0.0, power=0.8, alpha=0.05, paired=False, n_max=500):
    """Smallest n per engine (pairs if ``paired``) with equivalence_power >= ``power``.

    Returns None when the target is not reached for n <= n_max (always so
    when |true_diff| >= margin).
    """
    if abs(true_diff) >= margin:
        return None

    def ok(n):
        return equivalence_power(true_diff, sd, n, margin, alpha=alpha, paired=paired) >= power

    if not ok(n_max):
        return None
    lo, hi = 1, n_max  # the power rises with n: ok(hi) holds, ok(lo) does not (no df at n = 1)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


# ---------------------------------------------------------------- yes/no observables


def _check_counts(k_a, n_a, k_b, n_b, margin):
    for k, n in ((k_a, n_a), (k_b, n_b)):
        if not (0 <= int(k) <= int(n)) or int(k) != k or int(n) != n:
            raise ValueError(f"counts must be integers with 0 <= k <= n (got {k} of {n})")
    if not margin > 0:
        raise ValueError("margin must be positive")
    return int(k_a), int(n_a), int(k_b), int(n_b)


@functools.lru_cache(maxsize=100000)
def _newcombe(k_b, n_b, k_a, n_a, alpha):
    """Newcombe's hybrid score interval of p_b - p_a (statsmodels); it is
    defined at the boundaries (0 of n, n of n), where the score interval is not."""
    lo, hi = confint_proportions_2indep(k_b, n_b, k_a, n_a, method="newcomb", compare="diff", alpha=alpha)
    return float(lo), float(hi)


def verdict_proportions(k_a, n_a, k_b, n_b, margin, alpha=0.05, with_mdd=True):
    """Verdict on the difference of two fractions, k_b/n_b - k_a/n_a (e.g. the
    packings in which the big disk rose, in two engines), by the same rule as
    the scalar verdicts, with Newcombe's hybrid score intervals at 1 - 2 alpha
    (equivalence) and 1 - alpha (difference). ``mdd`` is the smallest true
    difference from the pooled fraction that is called different with
    probability 0.8 (exact, :func:`proportion_power`; None with ``with_mdd=False``,
    which saves its search)."""
    k_a, n_a, k_b, n_b = _check_counts(k_a, n_a, k_b, n_b, margin)
    if n_a < 2 or n_b < 2:
        diff = k_b / n_b - k_a / n_a if n_a and n_b else None
        return {"verdict": "inconclusive", "difference": diff, "ci90": None, "ci95": None, "tost_p": None,
                "margin": float(margin), "n_a": n_a, "n_b": n_b, "mdd": None, "reason": "too few runs"}
    diff = k_b / n_b - k_a / n_a
    ci90 = _newcombe(k_b, n_b, k_a, n_a, 2 * alpha)
    ci95 = _newcombe(k_b, n_b, k_a, n_a, alpha)
    mdd = proportion_mdd((k_a + k_b) / (n_a + n_b), n_a, n_b, margin, alpha) if with_mdd else None
    return _decide(diff, ci90, ci95, None, margin, alpha, n_a, n_b, mdd)


def _binomial_pmf(n, p):
    return stats.binom.pmf(np.arange(n + 1), n, p)


def _probability_of_counts(p_a, n_a, p_b, n_b, event):
    """Probability of event(k_a, k_b) for independent counts k_a ~ Bin(n_a, p_a)
    and k_b ~ Bin(n_b, p_b): exact, summed over every pair of counts (those of
    probability below 1e-12 left out)."""
    wa, wb = _binomial_pmf(n_a, p_a), _binomial_pmf(n_b, p_b)
    total = 0.0
    for ka in range(n_a + 1):
        if wa[ka] < 1e-12:
            continue
        for kb in range(n_b + 1):
            if wb[kb] >= 1e-12 and event(ka, kb):
                total += wa[ka] * wb[kb]
    return float(total)


def proportion_power(p_a, p_b, n_a, n_b, margin, alpha=0.05, outcome="equivalent"):
    """Probability that :func:`verdict_proportions` ends in ``outcome`` when the
    true fractions are p_a and p_b."""
    return _probability_of_counts(p_a, n_a, p_b, n_b,
                                  lambda ka, kb: _proportion_outcome(ka, n_a, kb, n_b, margin, alpha) == outcome)


@functools.lru_cache(maxsize=100000)
def _proportion_outcome(k_a, n_a, k_b, n_b, margin, alpha):
    diff = k_b / n_b - k_a / n_a
    lo90, hi90 = _newcombe(k_b, n_b, k_a, n_a, 2 * alpha)
    lo95, hi95 = _newcombe(k_b, n_b, k_a, n_a, alpha)
    if (lo90 == hi90 and -margin <= lo90 <= margin) or (-margin < lo90 and hi90 < margin):
        return "equivalent"
    if (lo95 > 0 or hi95 < 0) and max(abs(lo95), abs(hi95)) > margin:
        return "different"
    del diff
    return "inconclusive"


def proportion_mdd(p, n_a, n_b, margin, alpha=0.05, power=0.8):
    """Smallest true shift d of the fraction from p (up or down, whichever
    is found first in steps of 0.01) that :func:`verdict_proportions` calls
    different with probability ``power``; None when no shift within [0, 1]
    reaches it."""
    best = None
    for d in np.arange(0.01, 1.0001, 0.01):
        for pb in (p + d, p - d):
            if 0.0 <= pb <= 1.0 and proportion_power(p, pb, n_a, n_b, margin, alpha, "different") >= power:
                best = float(round(d, 2))
                break
        if best is not None:
            break
    return best


def threshold_test(k_above, n_above, k_below, n_below, alpha=0.05):
    """Whether a yes/no outcome (the big disk's rise) happens more often above a
    threshold than below it: Fisher's exact test, one-sided, at ``alpha``.
    Returns a dict with present (bool), p, the two fractions and a reason."""
    table = [[k_above, n_above - k_above], [k_below, n_below - k_below]]
    p = float(stats.fisher_exact(table, alternative="greater")[1])
    present = p < alpha
    fa, fb = (k_above / n_above if n_above else None), (k_below / n_below if n_below else None)
    reason = (f"{k_above}/{n_above} above against {k_below}/{n_below} below, one-sided Fisher p = {p:.2g}"
              f" {'<' if present else '>='} {alpha:g}")
    return {"present": bool(present), "p": p, "above_fraction": fa, "below_fraction": fb, "reason": reason}


@functools.lru_cache(maxsize=100000)
def _threshold_shown(k_above, n_above, k_below, n_below, alpha):
    return threshold_test(k_above, n_above, k_below, n_below, alpha)["present"]


@functools.lru_cache(maxsize=4096)
def threshold_power(p_above, n_above, p_below, n_below, alpha=0.05):
    """Probability that :func:`threshold_test` shows the threshold when the
    outcome happens with probability p_above in each of n_above runs above it
    and p_below in each of n_below runs below."""
    return _probability_of_counts(p_above, n_above, p_below, n_below,
                                  lambda ka, kb: _threshold_shown(ka, n_above, kb, n_below, alpha))
