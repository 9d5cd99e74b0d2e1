"""The library's own exceptions.

Every error svrqp raises on purpose derives from :class:`SvrqpError`, so callers can catch
the library's errors without catching programming mistakes. Input errors are also
``ValueError`` (scikit-learn's convention), singular systems are also
``numpy.linalg.LinAlgError``, and a missing optional backend is also ``ImportError``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np


class SvrqpError(Exception):
    """Base class of every error svrqp raises on purpose."""


class ProblemError(SvrqpError, ValueError):
    """A problem, dataset or parameter is invalid (shape, finiteness, sign, PSD, ...)."""


class InputTypeError(ProblemError, TypeError):
    """An input holds values of a type that cannot be
    numbers (also ``TypeError``, Python's convention)."""


class SolverError(SvrqpError, RuntimeError):
    r"""A backend failed, or returned a solution that misses the requested tolerance.

    ``coefficient_l1`` is :math:`\sum_i|\beta_i|` of the rejected ε-SVR answer, when there was
    one (how much its predictions cancel:
    :func:`svrqp.solvers.epsilon_svr.require_representable`).
    """

    def __init__(self, message: str, backend: str | None = None, status: str | None = None):
        super().__init__(message)
        self.backend = backend
        self.status = status
        self.coefficient_l1: float | None = None


class BackendNotAvailableError(SvrqpError, ImportError):
    """An optional backend is not installed; the message names the extra to install."""


class SingularSystemError(SvrqpError, np.linalg.LinAlgError):
    """A linear system or normal-equation matrix is singular or numerically rank deficient."""


class ExtrapolationWarning(UserWarning):
    """Rows to predict lie outside the input domain the model was fitted on.

    Raised by :class:`svrqp.Guarded` (``predict``, ``predict_interval``) when a row is outside
    the training range of an input or further from the training data than a calibrated
    Mahalanobis distance; ``Guarded.check_domain(X)`` says which inputs and by how much.
    """


@contextmanager
def input_errors_as_problem_errors() -> Iterator[None]:
    """Re-raise a ``ValueError`` or ``TypeError`` of input validation (scikit-learn's, numpy's) as
    :class:`ProblemError` or :class:`InputTypeError` with the same message, so bad input always
    ends in the library's error."""
    try:
        yield
    except SvrqpError:
        raise
    except TypeError as err:
        raise InputTypeError(str(err)) from err
    except ValueError as err:
        raise ProblemError(str(err)) from err
