"""Named fitted models for the export tests, one per exportable kind, each with why it is here."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from support.problems import position_error_11, thermal_two_sensors
from svrqp import LSSVR, EpsilonSVR
from svrqp.estimators import LinearLS, PolynomialLS, RecursiveLS


@dataclass(frozen=True)
class ExportCase:
    """A fitted model with its raw training data."""

    name: str
    model: Any
    X: pd.DataFrame
    y: pd.Series
    why: str


def thermal_raw() -> tuple[pd.DataFrame, pd.Series]:
    """``thermal_two_sensors`` back in raw units: T7_C ≈ 30–38 °C, T9_C ≈ 29–31 °C, error_um."""
    case = thermal_two_sensors()
    X = pd.DataFrame({"T7_C": 34.0 + 2.5 * case.X[:, 0], "T9_C": 30.0 + 0.6 * case.X[:, 1]})
    return X, pd.Series(case.y, name="error_um")


def _case(name: str, model: Any, why: str, data=thermal_raw) -> ExportCase:
    X, y = data()
    return ExportCase(name, model.fit(X, y), X, y, why)


def _position_11() -> tuple[pd.DataFrame, pd.Series]:
    case = position_error_11()
    return pd.DataFrame({"x_mm": case.X[:, 0] * 550.0}), pd.Series(case.y, name="delta_x_um")


def svr_scaled() -> ExportCase:
    return _case("svr_scaled", make_pipeline(StandardScaler(), EpsilonSVR(C=100.0, epsilon=0.2, gamma=0.5)),
                 "S0-style ε-SVR on standardised temperatures: the scaling must travel with the file")


def svr_raw_s0() -> ExportCase:
    return _case("svr_raw_s0", EpsilonSVR(C=24833.5, epsilon=0.2, gamma=0.125),
                 "S0's own parameters (g = 0.125, C = 24833.5) on raw temperatures: large coefficients")


def svr_poly() -> ExportCase:
    return _case("svr_poly", make_pipeline(StandardScaler(), EpsilonSVR(C=10.0, epsilon=0.1, kernel="poly",
                                                                        degree=3, gamma=0.5, coef0=1.0)),
                 "polynomial kernel: gamma, degree and coef0 in the file and the C evaluator")


def lssvr() -> ExportCase:
    return _case("lssvr", make_pipeline(StandardScaler(), LSSVR(C=10.0, gamma=0.5)),
                 "S4's LS-SVR: every training point is a support vector, no epsilon")


def lssvr_no_bias() -> ExportCase:
    return _case("lssvr_no_bias", make_pipeline(StandardScaler(), LSSVR(C=10.0, gamma=0.5, fit_intercept=False)),
                 "LS-SVR without bias: the cross-check reference is KernelRidge(alpha = 1/C)")


def mlr() -> ExportCase:
    return _case("mlr", LinearLS(), "S0 eq. (5): the MLR the papers compare against")


def rls_forgetting() -> ExportCase:
    return _case("rls_forgetting", RecursiveLS(forgetting=0.97),
                 "S3's recursion with forgetting: reference is exponentially weighted least squares")


def polynomial_5() -> ExportCase:
    return _case("polynomial_5", PolynomialLS(degree=5), "S2's 5th-order LSM of δx over 0–550 mm (Legendre basis)",
                 data=_position_11)


EXPORT_CASES = (svr_scaled, svr_raw_s0, svr_poly, lssvr, lssvr_no_bias, mlr, rls_forgetting, polynomial_5)


def box_grid(X: pd.DataFrame, n: int = 1000) -> np.ndarray:
    """``n`` evaluation points on a regular grid over the bounding box of ``X`` (1 or 2 inputs)."""
    low, high = X.min().to_numpy(), X.max().to_numpy()
    if X.shape[1] == 1:
        return np.linspace(low[0], high[0], n)[:, None]
    a, b = np.meshgrid(np.linspace(low[0], high[0], 40), np.linspace(low[1], high[1], n // 40))
    return np.column_stack([a.ravel(), b.ravel()])
