"""The screened warm start (svrqp.solvers.screening) and its place in the loose-SMO + crossover path.

Screening only chooses where the exact crossover starts, so every check here compares the final
answer with libsvm's SVR(tol=1e-8) and with the KKT conditions written out in numpy; the branches
(screening used, not used, the crossover misled and restarted from all points) are each forced.
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
from svrqp.kernels import gram
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.solvers import screening, warm_start

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


def noise_case(n: int = 1500, seed: int = 0) -> SVRCase:
    """Pure noise at small C: almost every point is a bounded support vector, none can be screened out."""
    rng = np.random.default_rng(seed)
    return SVRCase("noise", rng.normal(size=(n, 3)), rng.normal(size=n), C=1.0, epsilon=0.1, gamma=0.3,
                   why="nothing inside the tube")


def _screened(case: SVRCase):
    parameters = {**RBF, "gamma": case.gamma}
    products = KernelColumns(case.X, **parameters).products
    return screening.screened_fit(case.X, case.y, case.C, case.epsilon, parameters, 1e-3, products)


def _assert_exact(model, case):
    K = gram(case.X, gamma=case.gamma)
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case), case, K)


@pytest.mark.parametrize("C", [1.0, 100.0])
def test_screened_default_fit_matches_libsvm(C):
    case = dataclasses.replace(warm_up_case(), C=C)
    model = EpsilonSVR(C=C, epsilon=case.epsilon, gamma=case.gamma).fit(case.X, case.y)
    assert model.solution_.settings["screened_points"] > len(case.y) // 3
    assert model.solution_.settings["crossover_exact"]
    _assert_exact(model, case)


def test_screened_points_are_zero_in_the_start_and_mostly_at_the_optimum():
    case = warm_up_case()
    start = _screened(case)
    assert start is not None and start.screened >= screening.MIN_SCREENED * len(case.y)
    assert np.sum(start.beta == 0.0) >= start.screened
    # the exact optimum (libsvm at 1e-8) keeps all but a few of them inside the tube
    optimum = full_beta(reference(case), len(case.y))
    assert np.sum((start.beta == 0.0) & (optimum != 0.0)) <= screening.CROSSOVER_VIOLATORS


def test_no_screening_where_it_would_not_pay():
    assert _screened(noise_case()) is None  # few points inside the tube
    small = warm_up_case(n=screening.SCREEN_MIN_POINTS - 1)
    assert _screened(small) is None  # below the size where a pilot pays
    model = EpsilonSVR(C=1.0, epsilon=0.1, gamma=0.3).fit(noise_case().X, noise_case().y)
    assert model.solution_.settings["screened_points"] == 0
    _assert_exact(model, noise_case())


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
