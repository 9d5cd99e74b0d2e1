"""The models of svrqp by name: one table for the command line, the export format and the tools.

Each :class:`ModelSpec` ties together the short name a user types (``svrqp fit --model svr``),
the estimator class that fits it, the ``kind`` an exported ``svrqp.model/1`` document records
(the export format page, ``docs/export.md``), and which command-line options set its parameters.
The classes are named and imported from :mod:`svrqp.estimators` on first use, by a plain import
inside :meth:`ModelSpec.estimator_class` (so the architecture test sees the edge registry →
estimators), and reading the table imports no estimator (the export package and ``svrqp --help``
stay light).

>>> from svrqp import registry
>>> registry.names()
('svr', 'lssvr', 'mlr', 'poly', 'rls')
>>> registry.spec("svr").export_kind
'epsilon_svr'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from svrqp.exceptions import ProblemError


@dataclass(frozen=True)
class ModelSpec:
    """One model of the registry.

    Attributes
    ----------
    name
        The short name of the command line (``--model``) and of the tuning and gap tools.
    class_name
        The scikit-learn estimator's class, as :mod:`svrqp.estimators` exports it.
    export_kind
        The ``kind`` of its exported document (``svrqp.model/1``).
    parameters
        The estimator parameters the command line sets, each from the option of the same name.
    formula
        The form of its prediction, which the exported document stores and every evaluator
        (Python, C) computes: :data:`KERNEL` (support vectors, coefficients, a bias),
        :data:`LINEAR` (coefficients and an intercept) or :data:`LEGENDRE` (a Legendre series).
    summary
        What the model is, in a few words.
    tunable
        Whether :mod:`svrqp.tuning` searches its hyperparameters (the kernel models).
    baseline
        Whether ``svrqp gap`` can fit it as the baseline model (any number of inputs, one batch).
    """

    name: str
    class_name: str
    export_kind: str
    parameters: tuple[str, ...]
    formula: str
    summary: str
    tunable: bool = False
    baseline: bool = False

    def estimator_class(self) -> type:
        """The estimator class, imported on first use."""
        from svrqp import estimators

        return getattr(estimators, self.class_name)

    def make(self, **options: Any) -> Any:
        """An unfitted estimator with ``options`` that are
        among its :attr:`parameters` (others ignored)."""
        return self.estimator_class()(**{key: options[key] for key in self.parameters
                                         if key in options})


#: :attr:`ModelSpec.formula` of a kernel expansion :math:`\sum_i \beta_i k(u, x_i) + b`.
KERNEL = "kernel"
#: :attr:`ModelSpec.formula` of :math:`a_0 + u^\top a`.
LINEAR = "linear"
#: :attr:`ModelSpec.formula` of a Legendre series in one input.
LEGENDRE = "legendre"

#: The models, in the order the command line lists them.
MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("svr", "EpsilonSVR", "epsilon_svr", ("C", "epsilon", "gamma", "solver"),
              KERNEL, "ε-support vector regression, an explicit QP", tunable=True, baseline=True),
    ModelSpec("lssvr", "LSSVR", "ls_svr", ("C", "gamma"), KERNEL,
              "least-squares SVR, a KKT linear system", tunable=True, baseline=True),
    ModelSpec("mlr", "LinearLS", "linear_ls", (), LINEAR,
              "multiple linear regression, the normal equations", baseline=True),
    ModelSpec("poly", "PolynomialLS", "polynomial_ls", ("degree",), LEGENDRE,
              "polynomial in one input, Legendre basis"),
    ModelSpec("rls", "RecursiveLS", "recursive_ls", ("forgetting",), LINEAR,
              "recursive least squares with a forgetting factor"),
)

#: The baseline ``svrqp gap`` fits when none is named: multiple linear regression.
DEFAULT_BASELINE = "mlr"

_BY_NAME = {model.name: model for model in MODELS}
_BY_KIND = {model.export_kind: model for model in MODELS}


def names() -> tuple[str, ...]:
    """The short model names, in the order of :data:`MODELS`."""
    return tuple(_BY_NAME)


def tunable() -> tuple[str, ...]:
    """The names of the models whose hyperparameters :mod:`svrqp.tuning` searches."""
    return tuple(model.name for model in MODELS if model.tunable)


def baselines() -> tuple[str, ...]:
    """The names of the models ``svrqp gap`` can fit
    as its baseline, :data:`DEFAULT_BASELINE` first."""
    others = (model.name for model in MODELS if model.baseline and model.name != DEFAULT_BASELINE)
    return (DEFAULT_BASELINE, *others)


def export_kinds() -> tuple[str, ...]:
    """The ``kind`` of every exportable model, in the order of :data:`MODELS`."""
    return tuple(_BY_KIND)


def spec(name: str, option: str = "model") -> ModelSpec:
    """The model called ``name``.

    Raises
    ------
    ProblemError
        For a name that is not in :data:`MODELS` (the message lists the valid ones).
    """
    if name not in _BY_NAME:
        raise ProblemError(f"{option} must be one of {', '.join(names())}, got {name!r}")
    return _BY_NAME[name]


def spec_of_kind(kind: str) -> ModelSpec:
    """The model whose exported documents have ``kind``.

    Raises
    ------
    ProblemError
        For a kind that no model exports.
    """
    if kind not in _BY_KIND:
        raise ProblemError(f"kind must be one of {', '.join(export_kinds())}, got {kind!r}")
    return _BY_KIND[kind]


def formula(kind: str) -> str:
    """The :attr:`~ModelSpec.formula` of the model whose documents have ``kind``.

    Raises
    ------
    ProblemError
        For a kind that no model exports.
    """
    return spec_of_kind(kind).formula
