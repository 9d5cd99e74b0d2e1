"""Guarded models: calibrated prediction intervals and an input-domain guard.

:class:`Guarded` wraps any regressor; :mod:`~svrqp.guard.conformal` calibrates its intervals
(group-aware, by ``crepes``), :mod:`~svrqp.guard.domain` decides which rows are outside the
training conditions, and :mod:`~svrqp.guard.figures` draws measured-vs-predicted plots with the
interval as a band and out-of-domain stretches shaded.
"""

from __future__ import annotations

from svrqp.guard.conformal import GroupFallbackWarning
from svrqp.guard.domain import InputDomain
from svrqp.guard.estimator import Guarded

__all__ = ["GroupFallbackWarning", "Guarded", "InputDomain"]
