"""The scikit-learn regressors: kernel models (:mod:`~svrqp.estimators.kernel`: ``EpsilonSVR``,
``LSSVR``) and least-squares models (:mod:`~svrqp.estimators.linear`: ``LinearLS``,
``PolynomialLS``, ``RecursiveLS``); :mod:`~svrqp.estimators.fitted_state` keeps fitted kernel
models small."""

from svrqp.estimators.kernel import LSSVR, EpsilonSVR
from svrqp.estimators.linear import LinearLS, PolynomialLS, RecursiveLS, merge_models

__all__ = ["LSSVR", "EpsilonSVR", "LinearLS", "PolynomialLS", "RecursiveLS", "merge_models"]
