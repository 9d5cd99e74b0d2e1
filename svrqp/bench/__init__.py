"""The solver comparison behind ``svrqp bench``, one module per step.

- :mod:`~svrqp.bench.cases`: accuracy profiles, generated datasets, one dataset at one size;
- :mod:`~svrqp.bench.outcomes`: what one run produced, and the certificates of a model (β, b);
- :mod:`~svrqp.bench.runners`: one runner per method, each run in a child process with a time limit;
- :mod:`~svrqp.bench.evaluate`: result rows, success, per-method aggregates and ratios;
- :mod:`~svrqp.bench.run`: the configuration and the whole benchmark;
- :mod:`~svrqp.bench.report`: CSV, Markdown report and plot.

The recorded runs are the scripts in ``benchmarks/``.
"""
