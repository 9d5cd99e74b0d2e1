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
# # 01 — S0 (Miao et al. 2013): ε-SVR vs multiple regression for spindle thermal error
#
# S0 models the axial thermal error of a machining-centre spindle from two temperatures, T7
# (spindle box) and T9 (ambient), fitted on a summer batch `x1` and tested on a second summer batch
# `x2` and an autumn batch `x3`. It compares multiple linear regression (eq. 5) with an RBF ε-SVR
# whose $(C, g)$ come from 5-fold cross-validation, and concludes that the SVR is more robust across
# seasons. Its metric, called the "standard deviation" $s$, is computed as the **root mean square
# of the residuals** (§4.3: 残差均方根值), so every table here reports the RMS.
#
# **What is simulated:** `miao2013_rise` comes from svrqp's thermal simulator, not from S0 (its data
# are not public). It uses S0's representation — temperature **rises from the start of each run**
# and the probe zeroed at the start — because S0's Table 1 lists its support vectors as (T7, T9)
# pairs from (1.44, 0.25) to (7.25, 5.25) °C, which cannot be absolute temperatures at an ambient
# of 24–30 °C. The data card gives the evidence for each decision:

# %%
# %matplotlib inline
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import Markdown, Math, display
from sklearn.linear_model import LinearRegression
from sklearn.svm import SVR

from svrqp import EpsilonSVR, datasets, tuning
from svrqp.compensate import residual_metrics
from svrqp.formulations import epsilon_svr, least_squares
from svrqp.kernels import gram
from svrqp.estimators import LinearLS
from svrqp.problems import LinearSystem
from svrqp.solvers import solve_linear_system

card = datasets.card("miao2013_rise")
display(Markdown(card[card.index("## Decisions"):card.index("## Effects")]))
data = datasets.load("miao2013_rise")
features, target = ["T7_rise_C", "T9_rise_C"], "error_um"
batches = {name: rows for name, rows in data.groupby("batch")}
x1 = batches["x1"]
data.groupby("batch")[[*features, target]].agg(["min", "max"]).round(2)

# %% [markdown]
# ## Multiple linear regression (S0 eq. 5) — the normal equations, two ways
#
# S0 publishes $S = 3.7674\,T_7 - 0.4237\,T_9 - 2.7669$. With the design $D = [\mathbf 1, T_7, T_9]$ of
# batch `x1`, least squares is the linear system $D^\top D\,a = D^\top y$ (S3 eq. 6). We state it as a
# `LinearSystem`, solve it by LU (`solve_linear_system`) and by the equilibrated Cholesky
# factorisation that `LinearLS` uses, and referee both with scikit-learn and NumPy.

# %%
design = np.column_stack([np.ones(len(x1)), x1[features].to_numpy()])
normal = LinearSystem(M=design.T @ design, rhs=design.T @ x1[target].to_numpy(), name="normal equations of S0's MLR",
                      statement=r"D^\top D\,a = D^\top y,\quad D = [\mathbf 1,\ T_7,\ T_9]")
display(Math(normal.to_latex()))
by_lu = solve_linear_system(normal).x
by_cholesky = least_squares.solve_normal_equations(design, x1[target].to_numpy()).coef
mlr = LinearLS().fit(x1[features], x1[target])
sklearn_mlr = LinearRegression().fit(x1[features], x1[target])
pd.DataFrame({
    "LU of DᵀD a = Dᵀy": by_lu,
    "Cholesky (equilibrated)": by_cholesky,
    "LinearLS": [mlr.intercept_, *mlr.coef_],
    "scikit-learn LinearRegression": [sklearn_mlr.intercept_, *sklearn_mlr.coef_],
    "numpy lstsq": np.linalg.lstsq(design, x1[target].to_numpy(), rcond=None)[0],
    "S0 eq. 5": [-2.7669, 3.7674, -0.4237],
}, index=["a0 (μm)", "a_T7 (μm/°C)", "a_T9 (μm/°C)"])

# %%
display(Math(mlr.to_latex()))
print(f"largest difference between the four solutions: "
      f"{np.ptp(np.vstack([by_lu, by_cholesky, [mlr.intercept_, *mlr.coef_]]), axis=0).max():.2e}")

# %% [markdown]
# ## ε-SVR: the QP the model solved, two backends, scikit-learn as the referee
#
# S0 reports $g = 0.125$ (its RBF is $\exp(-\lVert\cdot\rVert^2/\sigma^2)$ with $g = 1/\sigma^2$, so
# $\gamma = g$) and $C = 24833.5$, with 56 support vectors and $b = 4.296$. ε is not stated; we use the
# probe's noise level, 0.3 μm. The fitted model keeps the QP it solved (`problem_`), printed here
# from the object, and its certificates (`solution_.residuals`).

# %%
epsilon = 0.3
X1, y1 = x1[features].to_numpy(), x1[target].to_numpy()
svr_paper = EpsilonSVR(C=24833.5, epsilon=epsilon, gamma=0.125, solver="clarabel").fit(x1[features], x1[target])
display(Math(svr_paper.problem_.to_latex()))
print(f"{svr_paper.problem_.n} variables; {svr_paper.support_.size} support vectors (S0: 56), "
      f"b = {svr_paper.intercept_[0]:.3f} μm (S0: 4.296)")

# %%
K = gram(X1, kernel="rbf", gamma=svr_paper.gamma_)
reference = SVR(kernel="rbf", C=24833.5, epsilon=epsilon, gamma=0.125, tol=1e-8).fit(X1, y1)
beta_reference = np.zeros(len(y1))
beta_reference[reference.support_] = reference.dual_coef_[0]
rows = []
for solver in ("clarabel", "piqp", "dual_ipm"):
    model = EpsilonSVR(C=24833.5, epsilon=epsilon, gamma=0.125, solver=solver).fit(X1, y1)
    beta = np.zeros(len(y1))
    beta[model.support_] = model.dual_coef_[0]
    rows.append({"solver": solver, "dual objective": epsilon_svr.dual_objective(K, y1, beta, epsilon),
                 "max primal/dual/gap residual": max(model.solution_.residuals[k] for k in ("primal_rel", "dual_rel", "gap_rel")),
                 "support vectors": model.support_.size, "b (μm)": model.intercept_[0],
                 "max |f − f_clarabel| (μm)": np.abs(model.predict(X1) - svr_paper.predict(x1[features])).max(),
                 "max |f − f_sklearn| (μm)": np.abs(model.predict(X1) - reference.predict(X1)).max()})
rows.append({"solver": "scikit-learn (libsvm)", "dual objective": epsilon_svr.dual_objective(K, y1, beta_reference, epsilon),
             "support vectors": reference.support_.size, "b (μm)": reference.intercept_[0]})
pd.DataFrame(rows).set_index("solver")

# %% [markdown]
# The three backends agree to their tolerance. libsvm stops at a slightly lower dual objective (the
# dual is maximised: higher is better); with $C$ this large its $b$ differs from ours by about
# 0.14 μm, its predictions by about 0.01 μm.
#
# ## Our own 5-fold CV
#
# S0 splits its training samples into the K folds **at random** (§3: 随机地分成 K 个互不相交的子集);
# so do we, with a fixed seed so that the notebook repeats (the folds `svrqp demo` uses too). The
# grid holds S0's own choice and reaches beyond the CV's choice on every side.

# %%
from sklearn.model_selection import KFold

grid = {"C": [10.0, 100.0, 1000.0, 1e4, 24833.5, 1e5], "gamma": [0.001, 0.003, 0.01, 0.03, 0.125]}
random_folds = KFold(5, shuffle=True, random_state=2013)
search = tuning.grid_search(X1, y1, **grid, epsilon=[epsilon],
                            execution=tuning.Execution(cv=random_folds, backend="sequential"))
print(f"5-fold CV, random folds (as S0): best {search.best_params}, CV MSE {search.best_mse:.3f} μm²; "
      f"on an edge of the grid: {search.edges() or 'none'}")
search.table.round(4).head(8)

# %% [markdown]
# **Variant, labelled: contiguous folds.** On a time series, random folds let the model interpolate
# between neighbouring minutes; contiguous blocks of the run (`KFold` without shuffling) are the
# stricter test. It is not S0's procedure, and is shown only beside it:

# %%
contiguous = tuning.grid_search(X1, y1, **grid, epsilon=[epsilon],
                                execution=tuning.Execution(cv=KFold(5), backend="sequential"))
print(f"5-fold CV, contiguous folds (variant): best {contiguous.best_params}, "
      f"CV MSE {contiguous.best_mse:.3f} μm²")

# %% [markdown]
# ## The comparison in S0's metric: RMS of the residuals

# %%
svr_cv = search.best_estimator().fit(x1[features], x1[target])
models = {"MLR (eq. 5)": mlr, "ε-SVR, S0 parameters": svr_paper, "ε-SVR, our 5-fold CV": svr_cv}
rows = []
for name, model in models.items():
    for batch, rows_b in batches.items():
        metrics = residual_metrics(rows_b[target].to_numpy() - model.predict(rows_b[features]))
        rows.append({"model": name, "batch": batch, "RMS (μm)": metrics.rms_um, "max |r| (μm)": metrics.max_abs_um})
ours = pd.DataFrame(rows).pivot(index="model", columns="batch", values="RMS (μm)").round(3)
ours.loc["MLR, S0 published (RMS)"] = [1.263, 1.295, 8.467]
ours.loc["ε-SVR, S0 published (RMS)"] = [0.353, 0.385, 1.017]
ours

# %% [markdown]
# ## Where the autumn inputs lie
#
# The summer runs start in the morning, when the air warms by about 5 °C over the run, so their
# rises span S0's Table 1 (T7 up to 7.25 °C, T9 up to 5.25 °C). Whether the autumn inputs stay
# inside that range decides whether the models interpolate or extrapolate there:

# %%
ranges = []
for feature in features:
    low, high = x1[feature].min(), x1[feature].max()
    for batch in ("x2", "x3"):
        values = batches[batch][feature]
        ranges.append({"input": feature, "batch": batch, "train range (°C)": f"{low:.2f} … {high:.2f}",
                       "batch range (°C)": f"{values.min():.2f} … {values.max():.2f}",
                       "rows outside (%)": 100 * ((values < low) | (values > high)).mean()})
pd.DataFrame(ranges).round(1)

# %%
x3 = batches["x3"]
fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), sharex=True)
axes[0].plot(x3["time_min"], x3[target], "k.", ms=3, label="measured (simulated)")
for name, model in models.items():
    axes[0].plot(x3["time_min"], model.predict(x3[features]), label=name)
    axes[1].plot(x3["time_min"], x3[target] - model.predict(x3[features]), label=name)
axes[0].set(xlabel="time (min)", ylabel="axial error since the run start (μm)", title="autumn batch x3")
axes[1].set(xlabel="time (min)", ylabel="residual (μm)", title="residual on x3")
axes[0].legend(fontsize="small"); axes[1].axhline(0, color="grey", lw=0.5)
plt.tight_layout()

# %% [markdown]
# ## The lesson of the absolute variant
#
# `miao2013` holds the same runs with absolute temperatures and the error counted from the machine
# at 20 °C — not S0's set-up, and its own runs: summer afternoons whose air hardly moved (its data
# card says why it keeps them). There every autumn input lies below the whole summer range, and the
# RBF model, far from all its support vectors, fails worse than the plane:

# %%
absolute = datasets.load("miao2013")
absolute_features = ["T7_C", "T9_C"]
a1 = absolute[absolute["batch"] == "x1"]
variant = {"MLR": LinearLS().fit(a1[absolute_features], a1[target]),
           "ε-SVR (CV choice above)": EpsilonSVR(**search.best_params).fit(a1[absolute_features], a1[target])}
pd.DataFrame({name: {batch: residual_metrics(rows_b[target].to_numpy()
                                             - model.predict(rows_b[absolute_features])).rms_um
                     for batch, rows_b in absolute.groupby("batch")}
              for name, model in variant.items()}).T.round(3).rename_axis("RMS (μm), absolute variant")

# %% [markdown]
# On S0's representation, with summer rises spanning S0's Table 1, S0's finding comes out in
# direction: the ε-SVR of our CV degrades less in autumn than the MLR, and stays under S0's 2 μm in
# both seasons (the table above; with S0's own C and g it would leave 2.6 μm on x3). The MLR's
# autumn error is much smaller than S0's 8.467 μm: the autumn rises lie inside the summer range,
# and what the plane misses there is mostly an offset.
# On absolute temperatures the comparison does not hold. Neither says that an RBF model is robust
# in general: it is as good as the range its training data covered. Notebook 06 diagnoses what the
# summer data never showed.
