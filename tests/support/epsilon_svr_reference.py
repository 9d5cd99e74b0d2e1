"""ε-SVR references for the cross-checks: libsvm's solution and the KKT conditions checked in numpy."""

from __future__ import annotations

import dataclasses

import numpy as np
from sklearn.svm import SVR

from svrqp.formulations.epsilon_svr import dual_objective


def full_beta(model, n: int) -> np.ndarray:
    beta = np.zeros(n)
    beta[model.support_] = model.dual_coef_[0]
    return beta


def assert_kkt(K, y, beta, b, C, epsilon, tol):
    """The ε-SVR optimality conditions, checked here without the library's own helpers."""
    scale = 1.0 + np.abs(y).max()
    assert abs(beta.sum()) <= tol * C * len(y), "equality constraint sum(beta) = 0"
    assert np.all(np.abs(beta) <= C * (1 + tol)), "box constraint |beta| <= C"
    r = y - (K @ beta + b)
    inside = np.abs(beta) <= tol * C
    at_bound = np.abs(beta) >= C * (1 - tol)
    free = ~inside & ~at_bound
    assert np.all(np.abs(r[inside]) <= epsilon + tol * scale), "non-SVs lie inside the tube"
    assert np.allclose(r[free], epsilon * np.sign(beta[free]), atol=tol * scale), "free SVs on the tube"
    assert np.all(r[at_bound] * np.sign(beta[at_bound]) >= epsilon - tol * scale), "bounded SVs outside"


def reference(case, kernel="rbf"):
    return SVR(kernel=kernel, C=case.C, epsilon=case.epsilon, gamma=case.gamma, tol=1e-8).fit(case.X, case.y)


def linear(case):
    """The case with the C of its linear-kernel checks."""
    return dataclasses.replace(case, C=case.C_linear or case.C)


def assert_matches_reference(model, ref, case, K):
    n, std = len(case.y), case.y.std()
    ours, theirs = full_beta(model, n), full_beta(ref, n)
    f_ours, f_theirs = dual_objective(K, case.y, ours, case.epsilon), dual_objective(K, case.y, theirs, case.epsilon)
    assert abs(f_ours - f_theirs) <= 1e-6 * abs(f_theirs)
    assert np.max(np.abs(model.predict(case.X) - ref.predict(case.X))) <= 1e-5 * std
    assert abs(model.intercept_[0] - ref.intercept_[0]) <= 1e-5 * std
    # Support sets agree up to coefficients below 1e-7·C (DESIGN §3).
    differ = set(model.support_) ^ set(ref.support_)
    assert all(max(abs(ours[i]), abs(theirs[i])) < 1e-7 * case.C for i in differ), differ
