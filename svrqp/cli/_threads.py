"""How many BLAS/OpenMP threads a ``svrqp`` command may use.

A command runs one process per worker (the S0 grid of ``svrqp demo``, a ``svrqp tune`` on joblib)
and each process would start one BLAS thread per core: on a 2-core machine ``svrqp demo --quick``
took 41 s with the default threads and 10 s with one thread each. So commands cap BLAS at
``--blas-threads`` threads per process (default 1); ``--blas-threads 0``
lifts the cap and leaves the libraries' own default.

The cap is set twice: as the usual environment variables, before numpy is imported by a command
(worker processes inherit them), and through threadpoolctl for libraries already loaded (the
command run inside a Python session).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence

#: The environment variables BLAS and OpenMP builds read at start-up.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                    "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
OPTION = "--blas-threads"
DEFAULT = 1


def requested(argv: Sequence[str]) -> int:
    """The ``--blas-threads`` value among the arguments before the command's name (default 1).

    A bad value is left for the option's own parser to report; here it counts as the default.
    """
    for index, argument in enumerate(argv):
        if not argument.startswith("-"):
            break  # the command's name: options after it are the command's own
        value = None
        if argument == OPTION and index + 1 < len(argv):
            value = argv[index + 1]
        elif argument.startswith(OPTION + "="):
            value = argument.split("=", 1)[1]
        if value is not None:
            with contextlib.suppress(ValueError):
                return max(int(value), 0)
    return DEFAULT


@contextlib.contextmanager
def capped(threads: int) -> Iterator[None]:
    """Cap BLAS/OpenMP at ``threads`` per process for the duration (0: no cap).

    Variables the user set explicitly are kept: they are a stronger statement than the default.
    """
    if threads <= 0:
        yield
        return
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = str(threads)
    try:
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=threads):
            yield
    finally:
        for name in added:
            os.environ.pop(name, None)
