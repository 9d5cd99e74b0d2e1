"""The screened warm start (svrqp.solvers.screening) and its place in the loose-SMO + crossover path.

Screening only chooses where the exact crossover starts, so every check here compares the final
answer with libsvm's SVR(tol=1e-8) and with the KKT conditions written out in numpy; the branches
(holds at zero, at ±C, none, the crossover misled and restarted from all points) are each forced.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from support.epsilon_svr_reference import (
    assert_kkt,
    assert_matches_reference,
    full_beta,
    reference,
)
from support.problems import SVRCase

from svrqp import EpsilonSVR
from svrqp.bench.cases import friedman1
from svrqp.kernels import gram
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.solvers import screening, warm_start
from svrqp.solvers.dual_ipm.crossover import CrossoverSettings, crossover

RBF = {"kernel": "rbf", "degree": 3, "coef0": 0.0}


def warm_up_case(n: int = 2000, seed: int = 0) -> SVRCase:
    """Ten noisy sensors on warm-up curves, a smooth error of two of them: most points end inside the tube."""
    rng = np.random.default_rng(seed)
    t_min = rng.uniform(0.0, 250.0, n)
    T_C = 20.0 + rng.uniform(2.0, 10.0, 10) * (1.0 - np.exp(-t_min[:, None] / rng.uniform(20.0, 120.0, 10)))
    T_C += rng.normal(0.0, 0.05, T_C.shape)
    error_um = 3.0 * (T_C[:, 0] - 20.0) - 1.2 * (T_C[:, 3] - 20.0) + rng.normal(0.0, 0.2, n)
    X = (T_C - T_C.mean(axis=0)) / T_C.std(axis=0)
    return SVRCase("warm_up", X, (error_um - error_um.mean()) / error_um.std(), C=1.0, epsilon=0.1, gamma=0.1,
                   why="smooth target, noisy readings: most points inside the tube")


def noise_case(n: int = 2000, seed: int = 0) -> SVRCase:
    """Pure noise at small C: most points end far outside the tube, at ±C."""
    rng = np.random.default_rng(seed)
    return SVRCase("noise", rng.normal(size=(n, 3)), rng.normal(size=n), C=1.0, epsilon=0.1, gamma=0.3,
                   why="most points outside the tube")


def friedman_case(n: int = 2000) -> SVRCase:
    """Friedman #1 at small C: most residuals end near the tube's edge, too close to hold."""
    X, y = friedman1(n, 10, 0)
    return SVRCase("friedman1", X, y, C=1.0, epsilon=0.1, gamma=1.0 / (X.shape[1] * X.var()),
                   why="residuals near the tube edge")


def _screened(case: SVRCase):
    parameters = {**RBF, "gamma": case.gamma}
    products = KernelColumns(case.X, **parameters).products
    return screening.screened_fit(case.X, case.y, case.C, case.epsilon, parameters, 1e-3, products)


def _assert_exact(model, case):
    K = gram(case.X, gamma=case.gamma)
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case), case, K)


@pytest.mark.parametrize(("case_factory", "C"), [(warm_up_case, 1.0), (warm_up_case, 100.0), (noise_case, 1.0)])
def test_screened_default_fit_matches_libsvm(case_factory, C):
    case = dataclasses.replace(case_factory(), C=C)
    model = EpsilonSVR(C=C, epsilon=case.epsilon, gamma=case.gamma).fit(case.X, case.y)
    assert model.solution_.settings["screened_points"] > len(case.y) // 3
    assert model.solution_.settings["crossover_exact"]
    _assert_exact(model, case)


@pytest.mark.parametrize("case_factory", [warm_up_case, noise_case])
def test_holds_match_the_optimum_but_for_a_few(case_factory):
    case = case_factory()
    start = _screened(case)
    assert start is not None and start.screened >= screening.MIN_SCREENED * len(case.y)
    held = start.held
    assert abs(start.beta[held].sum()) < 1e-9 * case.C  # the bounded holds are balanced
    # the exact optimum (libsvm at 1e-8) agrees with all but a few holds (0, or the bound held at)
    optimum = full_beta(reference(case), len(case.y))
    assert np.sum(held & (np.abs(optimum - start.beta) > 1e-6 * case.C)) <= screening.CROSSOVER_VIOLATORS


def test_no_screening_where_it_would_not_pay():
    case = friedman_case()
    assert _screened(case) is None  # few residuals far enough from the tube's edge
    assert _screened(warm_up_case(n=screening.SCREEN_MIN_POINTS - 1)) is None  # too small for a pilot to pay
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma).fit(case.X, case.y)
    assert model.solution_.settings["screened_points"] == 0
    _assert_exact(model, case)


def test_a_pilot_over_its_iteration_budget_holds_nothing(monkeypatch):
    case = warm_up_case()
    assert _screened(case) is not None
    monkeypatch.setattr(screening, "PILOT_ITERATIONS_PER_POINT", 0)  # every pilot runs out of iterations
    assert _screened(case) is None


def test_misled_crossover_restarts_from_all_points(monkeypatch):
    """When the crossover does not settle from the screened start, the loose run over all points is used."""
    calls, rows_seen = [], []
    real_crossover, real_fit = warm_start.crossover, warm_start.decomposition_fit

    def first_fails(*args, **kwargs):
        result = real_crossover(*args, **kwargs)
        calls.append(result.exact)
        if len(calls) == 1:
            result.exact, result.Kbeta = False, None
        return result

    def recording_fit(X, y, *args, **kwargs):
        rows_seen.append(kwargs.get("rows"))
        return real_fit(X, y, *args, **kwargs)

    monkeypatch.setattr(warm_start, "crossover", first_fails)
    monkeypatch.setattr(warm_start, "decomposition_fit", recording_fit)
    case = warm_up_case()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, solver="smo_crossover").fit(case.X, case.y)
    assert len(calls) == 2 and rows_seen == [None]  # one restart, over all points
    assert model.solution_.settings["screened_points"] == 0
    _assert_exact(model, case)


def test_crossover_from_a_held_start_reaches_the_same_optimum_with_or_without_primal_dual_steps():
    """The primal–dual steps tried first leave the feasible method another start; the optimum is the
    one the feasible method reaches alone."""
    case = warm_up_case()
    parameters = {**RBF, "gamma": case.gamma}
    columns = KernelColumns(case.X, **parameters)
    start = screening.screened_fit(case.X, case.y, case.C, case.epsilon, parameters, 1e-3, columns.products)
    results = [crossover(columns, case.y, case.C, case.epsilon, start.beta, settings=settings) for settings in (CrossoverSettings(), CrossoverSettings(fast_steps=0))]
    assert all(result.exact for result in results)
    np.testing.assert_allclose(results[1].beta, results[0].beta, rtol=0, atol=1e-9 * case.C)


# the second: one round, ended without a break, so that holds are released after its product
@pytest.mark.parametrize(("violators", "rounds"), [(screening.CROSSOVER_VIOLATORS, screening.MAX_ROUNDS), (-1, 1)])
def test_bounded_term_is_the_product_of_the_values_it_names(monkeypatch, violators, rounds):
    from sklearn.metrics.pairwise import rbf_kernel

    monkeypatch.setattr(screening, "CROSSOVER_VIOLATORS", violators)
    monkeypatch.setattr(screening, "MAX_ROUNDS", rounds)
    case = noise_case()  # most points held at ±C
    start = _screened(case)
    values, product = start.bounded_term
    bounded = np.flatnonzero(values)
    assert bounded.size and np.all(np.abs(values[bounded]) == case.C)
    np.testing.assert_allclose(product, rbf_kernel(case.X, case.X[bounded], gamma=case.gamma) @ values[bounded],
                               rtol=1e-12, atol=1e-12 * case.C * bounded.size)


def test_crossover_started_from_the_bounded_term_forms_fewer_columns_for_the_same_optimum():
    case = noise_case()  # most points held at ±C
    parameters = {**RBF, "gamma": case.gamma}

    class Counted(KernelColumns):
        formed = 0  # columns formed for the bounded term

        def products(self, idx, v):
            self.formed += np.unique(idx).size
            return super().products(idx, v)

    start = screening.screened_fit(case.X, case.y, case.C, case.epsilon, parameters, 1e-3,
                                   KernelColumns(case.X, **parameters).products)
    columns = {"plain": Counted(case.X, **parameters), "seeded": Counted(case.X, **parameters)}
    plain = crossover(columns["plain"], case.y, case.C, case.epsilon, start.beta)
    seeded = crossover(columns["seeded"], case.y, case.C, case.epsilon, start.beta, bounded_start=start.bounded_term)
    assert plain.exact and seeded.exact
    np.testing.assert_allclose(seeded.beta, plain.beta, rtol=0, atol=1e-9 * case.C)
    np.testing.assert_allclose(seeded.Kbeta, plain.Kbeta, rtol=0, atol=1e-9 * np.abs(case.y).max())
    assert columns["seeded"].formed + np.count_nonzero(start.bounded_term[0]) // 2 <= columns["plain"].formed


@pytest.mark.parametrize("kernel", ["rbf", "linear", "poly", "precomputed"])
def test_libsvm_binding_gives_what_public_svr_gives(kernel, monkeypatch):
    """The direct call to libsvm's binding and the public SVR (its fallback) give the same run."""
    rng = np.random.default_rng(1)
    X = rng.normal(size=(60, 3))
    y = np.sin(X[:, 0]) + 0.1 * rng.normal(size=60)
    parameters = {"kernel": kernel, "gamma": 0.4, "degree": 2, "coef0": 1.0}
    data = gram(X, **{**parameters, "kernel": "rbf"}) if kernel == "precomputed" else X
    direct = screening.libsvm_smo(data, y, 3.0, 0.1, parameters, 1e-3, 10_000)
    from sklearn.svm import _libsvm

    real = _libsvm.fit

    def missing(*args, **kwargs):  # another signature for our call; SVR.fit's own call still works
        if "sample_weight" in kwargs:
            return real(*args, **kwargs)
        raise TypeError("fit() got an unexpected keyword argument")

    monkeypatch.setattr(_libsvm, "fit", missing)
    public = screening.libsvm_smo(data, y, 3.0, 0.1, parameters, 1e-3, 10_000)
    np.testing.assert_array_equal(direct[0], public[0])
    np.testing.assert_allclose(direct[1], public[1], rtol=0, atol=1e-12)
    assert direct[2] == pytest.approx(public[2], abs=1e-12) and direct[3] == public[3]
    assert public[3] > 0 and 0 < direct[0].size < y.size


def test_libsvm_binding_refuses_non_finite_coefficients(monkeypatch):
    from sklearn.svm import _libsvm

    real = _libsvm.fit

    def overflowing(*args, **kwargs):
        support, vectors, counts, coef, intercept, *rest = real(*args, **kwargs)
        return (support, vectors, counts, coef * np.inf, intercept, *rest)

    monkeypatch.setattr(_libsvm, "fit", overflowing)
    X, y = np.arange(20.0)[:, None], np.sin(np.arange(20.0))
    with pytest.raises(ValueError, match="not finite"):
        screening.libsvm_smo(X, y, 1.0, 0.1, {**RBF, "gamma": 0.5}, 1e-3, 1000)
