# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 00 — The formulations: equations → matrices → solvers
#
# Every model in svrqp is an explicit convex problem. This notebook walks through the three of them
# on a toy data set small enough to print every matrix:
#
# 1. the **ε-SVR**: primal → Lagrangian → dual → the QP matrices $P, q, A, b, lb, ub$, solved by
#    three backends and refereed by scikit-learn;
# 2. the **LS-SVR** KKT linear system (S4 eq. 5);
# 3. the **normal equations** of least squares (S3 eq. 6).
#
# Each equation sits next to the code that builds it (printed with `inspect`).
#
# **What is simulated:** the data are six points of a made-up smooth positioning error
# $\delta_x(x)$ (μm) along a 550 mm axis, in the spirit of S2 — no paper data are used here.

# %%
import inspect
import time

import numpy as np
import pandas as pd
from IPython.display import Math, display
from sklearn.metrics.pairwise import rbf_kernel
from sklearn.svm import SVR

from svrqp.formulations import epsilon_svr, least_squares, ls_svr
from svrqp.kernels import gram
from svrqp.solvers import solve_linear_system, solve_qp

np.set_printoptions(precision=4, suppress=True, linewidth=120)

x_mm = np.linspace(0.0, 550.0, 6)
error_um = 0.012 * x_mm + 1.5 * np.sin(x_mm / 90.0)
X = (x_mm / 550.0)[:, None]          # the position scaled to [0, 1]: the kernel sees unitless inputs
y = error_um
C, epsilon, gamma = 10.0, 0.1, 2.0   # box bound, tube half-width (μm), RBF width (1/unit²)
pd.DataFrame({"x_mm": x_mm, "error_um": error_um})

# %% [markdown]
# ## 1. The kernel matrix
#
# $K_{ij} = k(x_i, x_j) = \exp(-\gamma\lVert x_i - x_j\rVert^2)$ — computed with matrix products and
# checked against scikit-learn's `rbf_kernel`.

# %%
K = gram(X, kernel="rbf", gamma=gamma)
print(K)
print("max |K - sklearn| =", np.abs(K - rbf_kernel(X, gamma=gamma)).max())

# %% [markdown]
# ## 2. The ε-SVR primal (S0 eqs. 1–2)
#
# $$
# \min_{w, b, \xi, \xi^*} \ \tfrac12 \lVert w\rVert^2 + C \sum_i (\xi_i + \xi_i^*)
# \quad\text{s.t.}\quad
# y_i - w\cdot\varphi(x_i) - b \le \varepsilon + \xi_i^*,\quad
# w\cdot\varphi(x_i) + b - y_i \le \varepsilon + \xi_i,\quad \xi, \xi^* \ge 0 .
# $$
#
# ## 3. The Lagrangian
#
# With multipliers $\alpha_i^*, \alpha_i \ge 0$ for the two tube constraints and
# $\eta_i^*, \eta_i \ge 0$ for $\xi^*, \xi \ge 0$:
#
# $$
# L = \tfrac12\lVert w\rVert^2 + C\sum_i(\xi_i + \xi_i^*)
#   - \sum_i \alpha_i^*\bigl(\varepsilon + \xi_i^* - y_i + w\cdot\varphi(x_i) + b\bigr)
#   - \sum_i \alpha_i\bigl(\varepsilon + \xi_i + y_i - w\cdot\varphi(x_i) - b\bigr)
#   - \sum_i (\eta_i^*\xi_i^* + \eta_i\xi_i) .
# $$
#
# Stationarity:
# $\partial_w L = 0 \Rightarrow w = \sum_i (\alpha_i^* - \alpha_i)\varphi(x_i)$;
# $\partial_b L = 0 \Rightarrow \sum_i (\alpha_i^* - \alpha_i) = 0$;
# $\partial_{\xi_i} L = 0 \Rightarrow C - \alpha_i - \eta_i = 0$, so $0 \le \alpha_i \le C$ (same for $\alpha_i^*$).
#
# ## 4. The dual (S0 eq. 6)
#
# Substituting back, with $\beta = \alpha^* - \alpha$ and $K_{ij} = \varphi(x_i)\cdot\varphi(x_j)$:
#
# $$
# \max_{\alpha, \alpha^*} \ -\tfrac12 (\alpha^*-\alpha)^\top K (\alpha^*-\alpha)
# - \varepsilon\, \mathbf 1^\top(\alpha^* + \alpha) + y^\top(\alpha^* - \alpha)
# \quad\text{s.t.}\quad \mathbf 1^\top(\alpha^* - \alpha) = 0,\quad 0 \le \alpha, \alpha^* \le C .
# $$
#
# ## 5. The dual as QP matrices
#
# Minimising the negated dual in $z = [\alpha; \alpha^*]$ gives
# $\min \tfrac12 z^\top P z + q^\top z$ s.t. $Az = b$, $lb \le z \le ub$ with
#
# $$
# P = \begin{bmatrix} K & -K\\ -K & K\end{bmatrix},\quad
# q = \begin{bmatrix}\varepsilon\mathbf 1 + y\\ \varepsilon\mathbf 1 - y\end{bmatrix},\quad
# A = [-\mathbf 1^\top,\ \mathbf 1^\top],\quad b = 0,\quad lb = 0,\quad ub = C .
# $$
#
# The function that builds them:

# %%
print(inspect.getsource(epsilon_svr.dual_stacked))

# %%
qp = epsilon_svr.dual_stacked(K, y, C, epsilon)
display(Math(qp.statement))
for name in ("P", "q", "A", "b", "lb", "ub"):
    print(f"{name} =\n{getattr(qp, name)}\n")

# %% [markdown]
# ## 6. Three backends, one problem — scikit-learn as the referee
#
# The same `QuadraticProgram` goes to Clarabel (interior point), OSQP (ADMM) and PIQP (proximal
# interior point). Every solution comes back with its certificates (relative primal residual, dual
# residual, duality gap) and is rejected if they miss the tolerance. The dual coefficients
# $\beta = \alpha^* - \alpha$ are compared with scikit-learn's `SVR.dual_coef_` (libsvm).

# %%
reference = SVR(kernel="rbf", C=C, epsilon=epsilon, gamma=gamma, tol=1e-10).fit(X, y)
beta_ref = np.zeros(len(y))
beta_ref[reference.support_] = reference.dual_coef_[0]

rows = []
for backend in ("clarabel", "osqp", "piqp"):
    solution = solve_qp(qp, backend, tol=1e-9)
    beta = epsilon_svr.beta_from_solution("stacked", len(y), solution.x)
    rows.append({
        "backend": backend,
        "dual objective": epsilon_svr.dual_objective(K, y, beta, epsilon),
        "primal_rel": solution.residuals["primal_rel"],
        "dual_rel": solution.residuals["dual_rel"],
        "gap_rel": solution.residuals["gap_rel"],
        "max |β − β_sklearn|": np.abs(beta - beta_ref).max(),
    })
rows.append({"backend": "sklearn (libsvm)", "dual objective": epsilon_svr.dual_objective(K, y, beta_ref, epsilon)})
pd.DataFrame(rows).set_index("backend")

# %% [markdown]
# ## 7. The bias from the KKT conditions
#
# With $r_i = y_i - (K\beta)_i$, a free support vector with $0 < \beta_i < C$ sits on the upper edge
# of the tube, so $b = r_i - \varepsilon$; one with $-C < \beta_i < 0$ on the lower edge,
# $b = r_i + \varepsilon$.

# %%
solution = solve_qp(qp, "clarabel", tol=1e-9)
beta = epsilon_svr.beta_from_solution("stacked", len(y), solution.x)
b = epsilon_svr.intercept_from_kkt(K, y, beta, C, epsilon)
print("β =", beta)
print(f"b = {b:.6f}   (scikit-learn: {reference.intercept_[0]:.6f})")
prediction = K @ beta + b
print("max |f(x) − sklearn| =", np.abs(prediction - reference.predict(X)).max(), "μm")

# %% [markdown]
# ## 8. The LS-SVR KKT system (S4 eqs. 4–5)
#
# LS-SVR replaces the tube by squared errors and the inequalities by equalities; its optimality
# conditions are one linear system, with $\Omega_{ij} = k(x_i, x_j)$:
#
# $$
# \begin{bmatrix} 0 & \mathbf 1^\top \\ \mathbf 1 & \Omega + C^{-1} I \end{bmatrix}
# \begin{bmatrix} b \\ \alpha \end{bmatrix}
# = \begin{bmatrix} 0 \\ y \end{bmatrix} .
# $$

# %%
print(inspect.getsource(ls_svr.kkt_system))
system = ls_svr.kkt_system(K, y, C)
print("M =\n", system.M, "\nrhs =", system.rhs)

# %% [markdown]
# It is solved by one Cholesky factorisation of $H = \Omega + C^{-1}I$ and the Schur complement:
# $H\nu = \mathbf 1$, $H\mu = y$, $b = \mathbf 1^\top\mu / \mathbf 1^\top\nu$, $\alpha = \mu - b\nu$.
# The reference is an LU solve of the full bordered system.

# %%
alpha, b_ls, info = ls_svr.solve_cholesky_schur(K, y, C)
lu = solve_linear_system(system)
print("Cholesky–Schur: b =", b_ls, " α =", alpha)
print("LU of the full system: b =", lu.x[0], " α =", lu.x[1:])
print("max difference:", np.abs(np.concatenate([[b_ls], alpha]) - lu.x).max())

# %% [markdown]
# ## 9. The normal equations (S3 eq. 6)
#
# A quadratic in $x$ fitted by least squares: $X^\top X a = X^\top y$, with the columns equilibrated
# before the Cholesky factorisation. The reference is NumPy's SVD-based `lstsq`.

# %%
design = np.column_stack([np.ones_like(x_mm), x_mm, x_mm**2])
print("XᵀX =\n", design.T @ design)
solution = least_squares.solve_normal_equations(design, y, column_names=["1", "x_mm", "x_mm²"])
reference = np.linalg.lstsq(design, y, rcond=None)[0]
print("a (normal equations) =", ", ".join(f"{a:.6e}" for a in solution.coef),
      f"  (condition number after equilibration: {solution.condition_number:.3g})")
print("a (numpy lstsq)      =", ", ".join(f"{a:.6e}" for a in reference))

# %% [markdown]
# ## What this showed
#
# - the ε-SVR dual is a small, explicit QP; three different algorithms agree with each other and
#   with libsvm to solver tolerance, and each solution carries its own certificates;
# - the bias is not a solver output but follows from the KKT conditions;
# - LS-SVR is a single linear system (one Cholesky), and least squares the normal equations.
#
# The formulation pages of the documentation map every one of these equations to the line of code
# that implements it.
