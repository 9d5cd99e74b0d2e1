"""Kernel linear algebra: blocked kernel columns (:mod:`~svrqp.linalg.kernel_columns`) and the
greedy pivoted Cholesky factor :math:`K \\approx LL^\\top`
(:mod:`~svrqp.linalg.pivoted_cholesky`)."""
