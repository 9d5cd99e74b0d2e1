"""The exact ε-SVR dual by a structure-exploiting interior point and an active-set crossover.

:mod:`~svrqp.solvers.dual_ipm.interior_point` (Newton steps on the reduced n×n system, dense or
low-rank), :mod:`~svrqp.solvers.dual_ipm.crossover` (active-set steps to the exact optimum) and
:mod:`~svrqp.solvers.dual_ipm.exact` (the two together, the low-rank path first when it applies) and
:mod:`~svrqp.solvers.dual_ipm.certified` (its answer
certified on a stated QP, as ``EpsilonSVR`` runs it).
"""

from svrqp.solvers.dual_ipm.crossover import (
    CrossoverResult,
    CrossoverSettings,
    DenseColumns,
    LinearColumns,
    crossover,
)
from svrqp.solvers.dual_ipm.exact import (
    ExactFit,
    ExactSettings,
    solve_exact,
    solve_exact_from_data,
)
from svrqp.solvers.dual_ipm.interior_point import IPMResult, interior_point
from svrqp.solvers.dual_ipm.kernel_operators import (
    DenseKernel,
    FactoredKernel,
    KernelOperator,
)

__all__ = ["CrossoverResult", "CrossoverSettings", "DenseColumns", "DenseKernel", "ExactFit",
           "ExactSettings", "FactoredKernel",
           "IPMResult", "KernelOperator", "LinearColumns", "crossover", "interior_point",
           "solve_exact", "solve_exact_from_data"]
