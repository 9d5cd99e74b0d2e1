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
# # 04 — S3 (Yang et al.): recursive least squares for an on-line thermal-error model
#
# S3 models the radial error of a turning centre with a linear model in four temperatures (eq. 25)
# and updates it after every workpiece by recursive least squares (eqs. 13–17), instead of keeping
# a static least-squares model. Over 50 workpieces it reports: static LS max |deviation| 12.55 μm,
# mean 8.15 μm; RLS 8.26 μm and 5.53 μm. It also merges models fitted on separate batches without
# the raw data (eqs. 20–24).
#
# **What is simulated:** `yang_turning` (50 workpieces, one measurement each) comes from svrqp's
# thermal simulator; its data card says what drives the error.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import scipy.linalg
from IPython.display import Math, display
from sklearn.linear_model import LinearRegression

from svrqp import datasets
from svrqp.compensate import online_compensation, residual_metrics
from svrqp.estimators import LinearLS, RecursiveLS, merge_models
from svrqp.problems import LinearSystem
from svrqp.solvers import solve_linear_system

data = datasets.load("yang_turning")
features, target = ["coolant_C", "nut_C", "spindle_C", "bed_C"], "error_um"
first, rest = data.iloc[:15], data.iloc[15:]
print(f"raw error: max |e| = {data[target].abs().max():.1f} μm")

# %% [markdown]
# ## Static model vs on-line recursion
#
# Both start from the first 15 workpieces. The static model is then frozen; the recursive one
# predicts each new workpiece *before* it is measured (that prediction is the compensation), then
# absorbs its measurement — S3's loop.

# %%
static = LinearLS().fit(first[features], first[target])
static_residual = rest[target].to_numpy() - static.predict(rest[features])
online = online_compensation(RecursiveLS().fit(first[features], first[target]), rest[features], rest[target])
forgetting = online_compensation(RecursiveLS(forgetting=0.9).fit(first[features], first[target]),
                                 rest[features], rest[target])
rows = {
    "static LS (ours)": residual_metrics(static_residual),
    "RLS, λ = 1 (ours)": online.run.after,
    "RLS, λ = 0.9 (ours)": forgetting.run.after,
}
table = pd.DataFrame({name: {"max |r| (μm)": m.max_abs_um, "mean |r| (μm)": m.mean_abs_um} for name, m in rows.items()}).T
table.loc["static LS (S3)"] = [12.55, 8.15]
table.loc["RLS (S3)"] = [8.26, 5.53]
table.round(2)

# %%
fig, ax = plt.subplots(figsize=(8, 3.4))
wp = rest["workpiece"]
ax.plot(wp, static_residual, "o-", ms=3, label="static LS")
ax.plot(wp, online.run.residual_um, "s-", ms=3, label="RLS λ = 1")
ax.plot(wp, forgetting.run.residual_um, "^-", ms=3, label="RLS λ = 0.9")
ax.axhline(0, color="grey", lw=0.5)
ax.set(xlabel="workpiece (-)", ylabel="residual after compensation (μm)")
ax.legend(fontsize="small");

# %% [markdown]
# ## The recursion is least squares, exactly
#
# With $\lambda = 1$, after all samples the recursive model equals the batch least-squares solution
# on the same data — a check that the recursion (S3 eqs. 13–17) is implemented right:

# %%
recursive = RecursiveLS().fit(data[features], data[target])
batch = LinearLS().fit(data[features], data[target])
print("max |coef RLS − coef batch| =", np.abs(recursive.coef_ - batch.coef_).max())
print("|intercept RLS − intercept batch| =", abs(recursive.intercept_ - batch.intercept_))
display(Math(batch.to_latex()))

# %% [markdown]
# ## The model's normal equations, from the model object, solved two ways
#
# The recursion carries $P_k^{-1} = \sum_i x_i x_i^\top$ and $b_k = \sum_i x_i y_i$ (S3 eqs. 20–24;
# the regressors are $x_i = (1, \theta_i - \theta_\mathrm{ref})$, centred on the first sample for
# conditioning), so the fitted `RecursiveLS` holds the linear system $P_k^{-1} a = b_k$ of S3 eq. 6.
# Stated as a `LinearSystem`, solved by LU and by Cholesky, and refereed by NumPy's `lstsq` and
# scikit-learn's `LinearRegression` on the same regressors:

# %%
state = recursive.state_
system = LinearSystem(M=state.information, rhs=state.b, name="S3 eq. 6 as the recursion holds it, 50 workpieces",
                      statement=r"P_k^{-1} a = b_k,\quad P_k^{-1} = \sum_i x_i x_i^\top,\quad b_k = \sum_i x_i y_i,"
                                r"\quad x_i = (1,\ \theta_i - \theta_\mathrm{ref})^\top")
display(Math(system.to_latex()))
y = data[target].to_numpy()
design = np.column_stack([np.ones(len(data)), data[features].to_numpy() - recursive.x_offset_])
reference = LinearRegression().fit(design[:, 1:], y)
pd.DataFrame({"LU": solve_linear_system(system).x,
              "Cholesky": scipy.linalg.cho_solve(scipy.linalg.cho_factor(state.information), state.b),
              "the recursion's a_k (eqs. 13–17)": state.a,
              "numpy lstsq": np.linalg.lstsq(design, y, rcond=None)[0],
              "scikit-learn": [reference.intercept_, *reference.coef_]},
             index=["a0 at θ_ref (μm)", *(f"a for {f} (μm/°C)" for f in features)])

# %% [markdown]
# ## Batch merge (S3 eqs. 20–24)
#
# Two machines (or two shifts) fit their own model; merging the models' $P^{-1}$ and $b$ gives the
# model of all the data, without exchanging the data:

# %%
morning, afternoon = data.iloc[:25], data.iloc[25:]
merged = merge_models(RecursiveLS().fit(morning[features], morning[target]),
                      RecursiveLS().fit(afternoon[features], afternoon[target]))
print("max |coef merged − coef refit on all| =", np.abs(merged.coef_ - batch.coef_).max())
