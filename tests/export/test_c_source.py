"""The generated C evaluator compiles warning-free and reproduces Python's predictions.

Each case is compiled with ``gcc -std=c99 -O2 -Wall -Wextra -pedantic -Werror`` together with a
small driver that reads points from stdin and prints ``svrqp_predict`` with ``%.17g`` (exact).
"""

from __future__ import annotations

import numpy as np
import pytest

from support.c_driver import run_driver
from support.export_cases import EXPORT_CASES, box_grid, svr_poly, svr_raw_s0
from svrqp.export import build_document, write
from svrqp.export.evaluate import term_magnitude

DRIVER = r"""
#include <stdio.h>
#include "svrqp_model.h"

int main(void)
{
    double x[SVRQP_N_INPUTS];
    for (;;) {
        int j;
        for (j = 0; j < SVRQP_N_INPUTS; ++j) {
            if (scanf("%lf", &x[j]) != 1) {
                return 0;
            }
        }
        printf("%.17g\n", svrqp_predict(x));
    }
}
"""

def c_predictions(gcc: str, document: dict, points: np.ndarray, directory) -> np.ndarray:
    source, header = write(document, directory)
    assert header.name == "svrqp_model.h" and "double svrqp_predict(const double *x);" in header.read_text()
    output = run_driver(gcc, DRIVER, source, points, directory)
    return np.array([float(value) for value in output.split()])


#: Models whose summed terms stay below 1e4 (target units): here 1e-12 absolute is a few units in
#: the last place of the sum, a meaningful test of "the C code computes the same function".
WELL_SCALED = [make for make in EXPORT_CASES if make not in (svr_raw_s0, svr_poly)]

#: Models whose terms reach 1e4–1e6 and cancel to a prediction of ~10: every double-precision
#: evaluator of them is off by ~eps·(sum of |terms|), so they are checked against extended precision.
LARGE_TERMS = [svr_raw_s0, svr_poly]


@pytest.mark.parametrize("make_case", WELL_SCALED, ids=lambda make: make.__name__)
def test_c_matches_python_to_1e12_on_1000_points(gcc, make_case, tmp_path):
    case = make_case()
    document = build_document(case.model, case.X, case.y)
    points = box_grid(case.X, 1000)
    assert len(points) == 1000
    assert term_magnitude(document, points).max() <= 1e4
    python = case.model.predict(case.X.__class__(points, columns=case.X.columns))
    c = c_predictions(gcc, document, points, tmp_path)
    assert c.shape == python.shape
    assert np.max(np.abs(c - python)) <= 1e-12 * max(1.0, np.max(np.abs(python)))  # relative past 1


def extended_precision_predict(document: dict, X: np.ndarray) -> np.ndarray:
    """The kernel model of ``document`` evaluated in long double (64-bit mantissa on x86)."""
    ld = np.longdouble
    U = np.asarray(X, dtype=ld)
    if document["scaling"] is not None:
        U = (U - np.array(document["scaling"]["mean"], dtype=ld)) / np.array(document["scaling"]["scale"], dtype=ld)
    model = document["model"]
    S = np.array(model["support_vectors"], dtype=ld)
    kernel = model["kernel"]
    if kernel["name"] == "rbf":
        K = np.exp(-ld(kernel["gamma"]) * ((U[:, None, :] - S[None, :, :]) ** 2).sum(axis=-1))
    else:
        K = (ld(kernel["gamma"]) * (U @ S.T) + ld(kernel["coef0"])) ** kernel["degree"]
    return K @ np.array(model["dual_coef"], dtype=ld) + ld(model["intercept"])


@pytest.mark.parametrize("make_case", LARGE_TERMS, ids=lambda make: make.__name__)
def test_c_is_accurate_to_rounding_when_terms_cancel(gcc, make_case, tmp_path):
    """The C result is within the a-priori rounding bound (n_SV + 4)·eps·Σ|terms| of the exact value.

    Summing n terms in double costs at most ~n·eps·Σ|terms| (Higham, recursive summation); the
    kernel and scaling add a few eps per term. The reference is the same formula in long double.
    """
    if np.finfo(np.longdouble).eps > 1e-18:
        pytest.skip("long double is no wider than double on this platform: no extended-precision reference")
    case = make_case()
    document = build_document(case.model, case.X, case.y)
    points = box_grid(case.X, 1000)
    magnitude = term_magnitude(document, points)
    assert magnitude.max() > 1e4  # these really are the large-term cases
    c = c_predictions(gcc, document, points, tmp_path)
    exact = extended_precision_predict(document, points)
    bound = (len(document["model"]["dual_coef"]) + 4) * np.finfo(float).eps * magnitude
    assert np.all(np.abs(c - exact) <= bound)
