r"""The transfer numbers of a kernel baseline
(``--model svr|lssvr``), from refits of that same family.

The contract (``docs/gap.md``, "What shrink means") defines :math:`\mathrm{RMSE}_\mathrm{refit}`
and :math:`\mathrm{RMSE}_\mathrm{after}` as refits of *the same model family*. For an ε-SVR or
LS-SVR baseline, leave-one-unit-out over all rows (the units of :mod:`svrqp.gap.transfer.linear`),

.. math::

    \mathrm{RMSE}_\mathrm{refit} &= \sqrt{\overline{(y_u - f_{-u}(X_u))^2}},\qquad
    \mathrm{RMSE}_\mathrm{after} = \sqrt{\overline{(y_u - g_{-u}([X, E_{\hat\tau_{-u}}]_u))^2}},

averaged over the real rows of every unit :math:`u`, where :math:`f_{-u}` and :math:`g_{-u}`
are the baseline's estimator (:func:`svrqp.gap.model.make_model`: the features and the
target standardised on the fit's own rows, an RBF kernel) fitted on every row outside :math:`u`
— for :math:`g`, on those where the effect is recorded. The hyper-parameters stay those of the
baseline: :math:`C` and :math:`\varepsilon` (in the fit's target standard deviations) as
documented in :mod:`svrqp.gap.model`, and :math:`\gamma` the number the baseline resolved on
its train rows (:attr:`svrqp.gap.model.Baseline.gamma`), also for the added standardised
effect columns. The effect's columns :math:`E` are those of the linear screen
(:meth:`svrqp.gap.transfer.ranking.TransferRanker.columns`); for ``lag`` the time constant
:math:`\hat\tau_{-u}` is the one the linear family chose inside the same fit's rows
(:attr:`svrqp.gap.results.records.TransferFit.variant`), so it never sees the held-out unit.

Screening stays linear
    Ranking, the surrogate tests and the conditional tests refit every candidate × transform
    hundreds of times; they use the linear family on shared normal equations
    (:mod:`svrqp.gap.transfer.ranking`). The kernel refits quantify the same-input refit and the
    :data:`KERNEL_CAUSES` best-ranked causes plus the verdict candidate; the report says which
    family each number comes from (``family``, ``screened_by``).

A failed refit
    A kernel refit whose solver cannot certify its answer (:class:`svrqp.exceptions.SolverError`,
    after the default path's own fallback) never aborts the diagnosis: the same-input refit's
    failure makes every number the linear family's, a cause's makes that cause's, and the JSON
    (``transfer.family_note`` or the cause's ``note``)
    and the reason say which refit failed and why.

Too few rows
    A fit on fewer than :data:`MIN_KERNEL_ROWS` rows is not made (an RBF model on a handful of
    rows says nothing about transfer): the effect — or, for the same-input refit, the whole
    report — keeps the linear family's numbers, and the JSON and the reason say so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from svrqp.exceptions import SolverError
from svrqp.gap.contract import LINEAR
from svrqp.gap.model import Baseline, fit_predict
from svrqp.gap.results.records import Ranking, TransferFit, Units
from svrqp.gap.transfer.ranking import TransferRanker

KERNEL_CAUSES = 3
"""Best-ranked causes whose transfer numbers are
refitted with the kernel family (and the verdict's)."""

MIN_KERNEL_ROWS = 20
"""Fewest rows a kernel refit is made on."""


class KernelTransfer:
    """Leave-one-unit-out refits of the baseline's kernel
    family, hyper-parameters fixed (module docstring).

    Parameters
    ----------
    kind : {"svr", "lssvr"}
        The baseline's family.
    gamma : float
        The baseline's resolved RBF width.
    X : ndarray, shape (n, p)
        The model's features on every row.
    y : ndarray, shape (n,)
        The target on every row.
    units : Units
        Held-out units.
    is_real : ndarray of bool, shape (n,)
        Rows scored.
    """

    def __init__(self, kind: str, gamma: float, X: np.ndarray, y: np.ndarray, units: Units,
                 is_real: np.ndarray):
        self.kind, self.gamma, self.X, self.y, self.units = kind, gamma, X, y, units
        self._real_of = [rows[is_real[rows]] for rows in units.rows()]
        self._real_position = np.cumsum(is_real) - 1  # row → position among the real rows
        self._n_real = int(is_real.sum())

    def refit(self) -> TransferFit | None:
        """The family with its own inputs only; None when a fit would have too few rows."""
        no_effect = np.zeros((self.y.size, 0))
        return self.errors(no_effect, [np.zeros(0, dtype=int)],
                           np.zeros(self.units.n_units, dtype=int))

    def errors(self, E: np.ndarray, variants: list[np.ndarray], chosen: np.ndarray,
               known: np.ndarray | None = None) -> TransferFit | None:
        """Leave-one-unit-out real-row errors with the effect columns added.

        Parameters
        ----------
        E : ndarray, shape (n, k)
            Every column any variant uses (non-finite where ``known`` is False).
        variants : list of ndarray of int
            Columns of ``E`` each variant adds (one per time constant for ``lag``).
        chosen : ndarray of int, shape (n_units,)
            The variant each unit's fit uses (the linear family's choice on the same rows).
        known : ndarray of bool, shape (n,), optional
            Rows where ``E`` is recorded; the fits use those only.

        Returns
        -------
        TransferFit or None
            None when some fit would have fewer than :data:`MIN_KERNEL_ROWS` rows.
        """
        known = np.isfinite(E).all(axis=1) if known is None else known
        fits = [known & (self.units.code != u) for u in range(self.units.n_units)]
        if min(int(rows.sum()) for rows in fits) < MIN_KERNEL_ROWS:
            return None
        out = np.empty(self._n_real)
        for u, (fit_rows, real) in enumerate(zip(fits, self._real_of, strict=True)):
            design = np.column_stack([self.X, E[:, variants[chosen[u]]]])
            predicted = fit_predict(self.kind, design[fit_rows], self.y[fit_rows], design[real],
                                    self.gamma)
            out[self._real_position[real]] = self.y[real] - predicted
        return TransferFit(out, np.asarray(chosen))


@dataclass(frozen=True)
class FamilyErrors:
    """The real-row errors the report's transfer numbers come from.

    Attributes
    ----------
    family : str
        The family of the same-input refit (``"linear"``, ``"svr"`` or ``"lssvr"``).
    refit : ndarray, shape (n_real,)
        Errors of that family's same-input refit.
    linear_refit : ndarray, shape (n_real,)
        Errors of the linear family's same-input refit (the footing of causes kept linear).
    after : dict of str to ndarray
        Errors of the same-family refit with each re-quantified cause's effect, by column.
    note : str or None
        Why the kernel family could not be used at all (stated fallback), else None.
    kept_linear : dict of str to str
        Causes the kernel family could not refit, with why.
    """

    family: str
    refit: np.ndarray
    linear_refit: np.ndarray
    after: dict[str, np.ndarray] = field(default_factory=dict)
    note: str | None = None
    kept_linear: dict[str, str] = field(default_factory=dict)

    def of(self, column: str) -> tuple[str, np.ndarray, np.ndarray | None]:
        """The family, the refit errors and the errors with
        the effect of one cause (None: the linear screen's)."""
        if column in self.after:
            return self.family, self.refit, self.after[column]
        return LINEAR, self.linear_refit, None


def same_family_errors(baseline: Baseline, ranker: TransferRanker,
                       ranking: Ranking) -> FamilyErrors:
    """The kernel family's refits of the same inputs and of the best causes (module docstring).

    The rows and the held-out units are the linear screen's (``ranker.data``,
    ``ranker.family.units``). ``mlr`` and prediction mode: the linear screen is the family,
    nothing is refitted again.
    """
    linear = ranker.refit.errors
    if baseline.kind not in ("svr", "lssvr"):
        return FamilyErrors(LINEAR, linear, linear)
    data, units = ranker.data, ranker.family.units
    kernel = KernelTransfer(baseline.kind, baseline.gamma, data.X, data.y, units, data.is_real)
    try:
        refit = kernel.refit()
    except SolverError as err:
        why = (str(err) or type(err).__name__).splitlines()[0][:160]
        note = (f"a leave-one-unit-out refit of the {baseline.kind} failed ({why}), so every "
                "transfer number comes from the linear family")
        return FamilyErrors(LINEAR, linear, linear, note=note)
    if refit is None:
        note = (f"a leave-one-unit-out refit of the {baseline.kind} would rest on fewer than "
                f"{MIN_KERNEL_ROWS} rows, so every transfer number comes from the linear family")
        return FamilyErrors(LINEAR, linear, linear, note=note)
    rows = ranking.ranked[:KERNEL_CAUSES]
    if ranking.top is not None and all(ranking.top is not row for row in rows):
        rows = [*rows, ranking.top]
    after, kept_linear = {}, {}
    for row in rows:
        E, variants, known = ranker.columns(row.effect)
        try:
            fit = kernel.errors(E, variants, row.fit.variant, known)
        except SolverError as err:
            why = (str(err) or type(err).__name__).splitlines()[0][:160]
            kept_linear[row.effect.column] = (
                f"its {baseline.kind} refit failed ({why}): linear-family numbers"
            )
            continue
        if fit is None:
            kept_linear[row.effect.column] = (f"recorded on too few rows for a {baseline.kind} "
                                              "refit without a held-out unit (fewer than "
                                              f"{MIN_KERNEL_ROWS}): linear-family numbers")
        else:
            after[row.effect.column] = fit.errors
    return FamilyErrors(baseline.kind, refit.errors, linear, after, None, kept_linear)
