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
# # 03 — S2 (Zhou et al.): improved nine-line identification and an SVR of the positioning error
#
# S2 measures the X axis of a five-axis gantry with a laser interferometer at 11 positions along
# three lines (at 20 °C, machine and instrument soaked), identifies the six error components per
# position by the **improved nine-line method** (nine readings, least squares through the normal
# equations) instead of the original six-reading method, then models the positioning error
# $\delta_x(x)$ with an RBF SVR ($C = 11.3137$, $\sigma = 0.5946$, chosen by 5-fold CV). It reports
# an MSE of the fit at the 11 positions of 0.0238 for the SVR against 0.072 for a 5th-order
# least-squares polynomial.
#
# **What is simulated:** the readings (`zhou_axis_x`) and the true error components of the same
# simulated axis (`zhou_axis_x_true`) come from svrqp's geometry simulator — so here, unlike in a
# laboratory, the identified components can be compared with the truth. The data card states each
# decision with S2's evidence.

# %%
# %matplotlib inline
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import Math, display
from sklearn.model_selection import KFold
from sklearn.svm import SVR

from svrqp import EpsilonSVR, datasets, tuning
from svrqp.formulations import epsilon_svr, least_squares, nine_line
from svrqp.kernels import gamma_from_sigma_s0, gram
from svrqp.estimators import PolynomialLS
from svrqp.datasets.build import ZHOU_AXIS
from svrqp.machine.geometry import measure_nine_line
from svrqp.problems import LinearSystem
from svrqp.solvers import solve_linear_system

readings = datasets.load("zhou_axis_x")
truth = datasets.load("zhou_axis_x_true").set_index("x_mm")
readings.head(6)

# %% [markdown]
# ## The improved identification as a linear system, solved two ways
#
# At each position the nine readings satisfy $\Delta = A\varepsilon$ (S2 eq. 3) with
# $\varepsilon = (\delta_x, \delta_y, \delta_z, \theta_x, \theta_y, \theta_z)$; the improved method
# solves the normal equations $A^\top A\,\varepsilon = A^\top\Delta$ (S2 eq. 5). At the first
# position, as a `LinearSystem`, by LU and by the equilibrated Cholesky factorisation that
# `identify_improved` uses, against NumPy's SVD-based `lstsq`:

# %%
first = readings[readings["x_mm"] == readings["x_mm"].min()]
offsets = first[["x_off_mm", "y_off_mm", "z_off_mm"]].to_numpy()
A = nine_line.nine_line_matrix(offsets, np.ones((3, 3), dtype=bool))
delta = first[["dx_um", "dy_um", "dz_um"]].to_numpy().ravel()
system = LinearSystem(M=A.T @ A, rhs=A.T @ delta, name="improved nine-line, one position",
                      statement=r"A^\top A\,\varepsilon = A^\top \Delta,\quad A \in \mathbb{R}^{9\times 6}")
display(Math(system.to_latex()))
pd.DataFrame({"LU": solve_linear_system(system).x,
              "Cholesky (equilibrated)": least_squares.solve_normal_equations(A, delta).coef,
              "numpy lstsq": np.linalg.lstsq(A, delta, rcond=None)[0],
              "identify_improved": nine_line.identify_improved(readings).iloc[0][list(nine_line.COMPONENTS)].to_numpy(dtype=float)},
             index=list(nine_line.COMPONENTS))

# %% [markdown]
# ## Original vs improved identification, component by component
#
# The original method uses $\Delta x$ on lines 1–3, $\Delta y$ on lines 1–2 and $\Delta z$ on line 1
# (a square 6×6 system). Units: μm for $\delta$, μrad for $\theta$.

# %%
original_readings = readings.copy()
original_readings.loc[original_readings["line"] == 3, ["dy_um", "dz_um"]] = np.nan
original_readings.loc[original_readings["line"] == 2, "dz_um"] = np.nan
improved = nine_line.identify_improved(readings).set_index("x_mm")
original = nine_line.identify_original(original_readings).set_index("x_mm")
errors = pd.DataFrame({
    "original": np.sqrt(((original - truth) ** 2).mean()),
    "improved": np.sqrt(((improved - truth) ** 2).mean()),
}).rename_axis("RMS identification error")
errors["improved is closer"] = errors["improved"] < errors["original"]
print(f"the improved method is closer on {errors['improved is closer'].sum()} of {len(errors)} components")
errors.round(4)

# %% [markdown]
# The count above is by the RMS over the 11 positions; by the largest error over the positions (the
# table of `svrqp demo`) the improved method is not closer on $\theta_z$. Neither is a property of
# the method alone. Switch the reading noise off and both
# methods are exact, so their difference is *only* what each does with the noise — nine readings
# averaged by least squares against six solved exactly, the noise of $\Delta x$ carried into the
# angles by $1/(\text{line offset})$. It depends on the noise draw and on the 100–200 mm offsets of
# the measuring lines.

# %%
quiet_axis = replace(ZHOU_AXIS, measurement_noise=0.0)
noise_free = nine_line.identify_improved(measure_nine_line(quiet_axis, "improved")).set_index("x_mm")
noise_free_original = nine_line.identify_original(measure_nine_line(quiet_axis, "original")).set_index("x_mm")
print("noise-free readings, largest |identified − true|: improved "
      f"{np.abs(noise_free - truth).to_numpy().max():.1e}, original {np.abs(noise_free_original - truth).to_numpy().max():.1e} "
      "(the 6-decimal rounding of the truth table)")

# %% [markdown]
# ## SVR of the positioning error $\delta_x(x)$
#
# S2 writes the RBF with $\sigma$ (S0's convention, $\gamma = 1/\sigma^2$) on a normalised position;
# we scale $x$ to $u = x/550 \in [0, 1]$. S2 does not state ε; we use 0.05 μm. Besides S2's parameters
# we choose $(C, \gamma)$ by our own 5-fold CV (shuffled folds: neighbouring positions are what the
# model must interpolate between). The fitted model prints the QP it solved:

# %%
x_mm = improved.index.to_numpy()
u = (x_mm / 550.0)[:, None]
delta_x = improved["delta_x_um"].to_numpy()
epsilon = 0.05
svr_paper = EpsilonSVR(C=11.3137, epsilon=epsilon, gamma=gamma_from_sigma_s0(0.5946)).fit(u, delta_x)
display(Math(svr_paper.problem_.to_latex()))
search = tuning.grid_search(u, delta_x, C=[1.0, 11.3137, 100.0, 1000.0], gamma=[1.0, 2.83, 10.0, 30.0],
                            epsilon=[epsilon], execution=tuning.Execution(cv=KFold(5, shuffle=True, random_state=0),
                                                                          backend="sequential"))
svr_cv = search.best_estimator().fit(u, delta_x)
print(f"S2's parameters: {svr_paper.support_.size} support vectors (S2: 10), b = {svr_paper.intercept_[0]:.3f} μm "
      f"(S2: −0.118); CV choice: {search.best_params} (CV MSE {search.best_mse:.4f} μm²)")

# %%
K = gram(u, kernel="rbf", gamma=svr_paper.gamma_)
reference = SVR(kernel="rbf", C=11.3137, epsilon=epsilon, gamma=gamma_from_sigma_s0(0.5946), tol=1e-10).fit(u, delta_x)
fine_u = np.linspace(0.0, 1.0, 551)[:, None]
rows = []
for solver in ("clarabel", "osqp", "piqp"):
    model = EpsilonSVR(C=11.3137, epsilon=epsilon, gamma=gamma_from_sigma_s0(0.5946), solver=solver).fit(u, delta_x)
    beta = np.zeros(len(delta_x))
    beta[model.support_] = model.dual_coef_[0]
    rows.append({"solver": solver, "dual objective": epsilon_svr.dual_objective(K, delta_x, beta, epsilon),
                 "support vectors": model.support_.size, "b (μm)": model.intercept_[0],
                 "max |f − f_sklearn| over the travel (μm)": np.abs(model.predict(fine_u) - reference.predict(fine_u)).max()})
beta_reference = np.zeros(len(delta_x))
beta_reference[reference.support_] = reference.dual_coef_[0]
rows.append({"solver": "scikit-learn (libsvm)", "dual objective": epsilon_svr.dual_objective(K, delta_x, beta_reference, epsilon),
             "support vectors": reference.support_.size, "b (μm)": reference.intercept_[0]})
pd.DataFrame(rows).set_index("solver")

# %% [markdown]
# ## SVR against the 5th-order polynomial
#
# The polynomial is least squares on the Legendre basis; NumPy's `Polynomial.fit` is the referee.
# S2's metric is the MSE of the fit at the 11 positions (in sample); leave-one-out and the error
# against the *true* δx, which only a simulator knows, say more.

# %%
poly = PolynomialLS(degree=5).fit(x_mm[:, None], delta_x)
numpy_poly = np.polynomial.Polynomial.fit(x_mm, delta_x, 5)
print(f"max |PolynomialLS − numpy Polynomial.fit| over the travel: "
      f"{np.abs(poly.predict(fine_u * 550.0) - numpy_poly(fine_u[:, 0] * 550.0)).max():.1e} μm")


def loo_mse(make, inputs):
    errors = [delta_x[i] - make().fit(np.delete(inputs, i, axis=0), np.delete(delta_x, i)).predict(inputs[i:i + 1])[0]
              for i in range(len(delta_x))]
    return float(np.mean(np.square(errors)))


rows = []
for name, make, inputs in (("ε-SVR, S2 parameters", lambda: EpsilonSVR(C=11.3137, epsilon=epsilon, gamma=gamma_from_sigma_s0(0.5946)), u),
                           ("ε-SVR, our 5-fold CV", search.best_estimator, u),
                           ("5th-order polynomial LS", lambda: PolynomialLS(degree=5), x_mm[:, None])):
    fitted = make().fit(inputs, delta_x)
    rows.append({"model": name, "fit MSE, S2's metric (μm²)": np.mean((fitted.predict(inputs) - delta_x) ** 2),
                 "leave-one-out MSE (μm²)": loo_mse(make, inputs),
                 "MSE vs true δx (μm²)": np.mean((fitted.predict(inputs) - truth["delta_x_um"].to_numpy()) ** 2)})
comparison = pd.DataFrame(rows).set_index("model")
comparison.loc["S2 published: SVR", "fit MSE, S2's metric (μm²)"] = 0.0238
comparison.loc["S2 published: polynomial", "fit MSE, S2's metric (μm²)"] = 0.072
comparison.round(4)

# %% [markdown]
# S2 publishes 0.0238 μm² (SVR) and 0.072 μm² (polynomial). The reading noise of `zhou_axis_x`
# (σ = 0.5 μm, its data card) is calibrated so that the polynomial's fit MSE is S2's 0.072 μm² in
# expectation over the noise. Why the SVR does not come out ahead, measured: the simulated δx is a
# scale error plus smooth shapes of degree ≤ 4, which a 5th-order polynomial follows exactly at the
# 11 positions — all it leaves is the reading noise it cannot absorb:

# %%
true_dx = truth["delta_x_um"].to_numpy()
on_truth = PolynomialLS(degree=5).fit(x_mm[:, None], true_dx)
print(f"5th-order polynomial fitted to the true δx (noise-free): MSE {np.mean((on_truth.predict(x_mm[:, None]) - true_dx) ** 2):.1e} μm²")

# %% [markdown]
# **The periodic variant.** Real ball screws add a periodic lead error; S2's MSEs leave no room for
# one, so it lives in the variant `zhou_axis_x_periodic` (1 μm, 16 mm lead), not in the default data.
# Sampled every 55 mm, 3.4 leads apart, it is **aliased**: at the 11 positions it looks like noise
# that no smooth model can follow, and it sets a floor under both models:

# %%
variant_truth = datasets.load("zhou_axis_x_periodic_true").set_index("x_mm")
periodic = (variant_truth["delta_x_um"] - truth["delta_x_um"]).to_numpy()
print(f"mean square of the periodic error at the 11 positions: {np.mean(periodic**2):.3f} μm² "
      f"({np.mean(periodic**2) / 0.0238:.0f}× S2's SVR MSE)")
variant_dx = nine_line.identify_improved(datasets.load("zhou_axis_x_periodic"))["delta_x_um"].to_numpy()
for name, fitted, inputs in (("ε-SVR (CV choice above)", search.best_estimator(), u),
                             ("polynomial", PolynomialLS(degree=5), x_mm[:, None])):
    fitted.fit(inputs, variant_dx)
    print(f"{name} on the periodic variant: fit MSE {np.mean((fitted.predict(inputs) - variant_dx) ** 2):.3f} μm²")

# %%
fine_mm = fine_u[:, 0] * 550.0
fig, ax = plt.subplots(figsize=(8, 3.4))
ax.plot(truth.index, truth["delta_x_um"], "k--", lw=1, label="true δx at the 11 positions (simulator)")
ax.plot(x_mm, delta_x, "ko", label="identified (improved nine-line)")
ax.plot(fine_mm, svr_cv.predict(fine_u), label="ε-SVR (CV)")
ax.plot(fine_mm, poly.predict(fine_mm[:, None]), label="5th-order polynomial")
ax.set(xlabel="x (mm)", ylabel="positioning error δx (μm)")
ax.legend(fontsize="small");

# %% [markdown]
# With 11 points, a "fit MSE" says little: a flexible enough model passes near every point. On this
# axis S2's in-sample ranking does not carry over: the polynomial, which follows the simulated δx
# exactly, is left with only the share of the reading noise it cannot absorb, while the CV-tuned SVR
# predicts better between the samples (leave-one-out) and comes closer to the true δx. S2's result
# needs structure in δx that a 5th-order polynomial cannot follow; S2 does not describe any, and none
# is invented here. A measurement that must capture a periodic lead error needs a pitch finer than
# the screw lead, or one not commensurate with it.
