"""The solver comparison behind ``svrqp bench``: the harness (:mod:`~svrqp.bench.harness`) and
its report (:mod:`~svrqp.bench.report`); the recorded runs are the scripts in ``benchmarks/``."""
