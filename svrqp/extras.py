"""The optional extras of svrqp: which package each brings, and one error that names the extra.

A core install (``pip install svrqp``) runs every command; a feature that needs an optional
package checks for it *before* any work or any file is written, with
:func:`require`, and stops with one line that names the extra to install.

- ``guard`` (crepes): conformal intervals — ``Guarded``, ``--coverage``, ``svrqp demo``;
- ``ga`` (pygad): the genetic-algorithm search — ``svrqp tune --method ga``;
- ``dask`` (distributed): searches on a Dask cluster — ``backend="dask"``, ``--scheduler``;
- ``parquet`` (pyarrow): Parquet input files;
- ``solvers`` (proxsuite, piqp, …): QP backends beyond Clarabel, OSQP and cvxpy (checked per
  backend by :mod:`svrqp.solvers.qp_backends`).
"""

from __future__ import annotations

import importlib.util

from svrqp.exceptions import BackendNotAvailableError

#: extra -> the module whose presence means the extra is installed.
EXTRA_MODULES: dict[str, str] = {
    "guard": "crepes",
    "ga": "pygad",
    "dask": "distributed",
    "parquet": "pyarrow",
}


def install_hint(extra: str) -> str:
    """The command that installs ``extra`` (several: comma-separated, ``"guard,ga"``)."""
    return f"pip install 'svrqp[{extra}]'"


def has_extra(extra: str) -> bool:
    """True when the package behind ``extra`` can be imported here."""
    if extra not in EXTRA_MODULES:
        raise KeyError(f"unknown extra {extra!r}; known: {', '.join(sorted(EXTRA_MODULES))}")
    return importlib.util.find_spec(EXTRA_MODULES[extra]) is not None


def require(extra: str | tuple[str, ...], purpose: str) -> None:
    """Raise :class:`~svrqp.exceptions.BackendNotAvailableError` unless ``extra`` is installed.

    Parameters
    ----------
    extra
        A key of :data:`EXTRA_MODULES`, or several: every missing one is named in one line.
    purpose
        What needs it, the start of the message (``"svrqp demo"``, ``"calibrated intervals"``).
    """
    missing = [e for e in ((extra,) if isinstance(extra, str) else extra) if not has_extra(e)]
    if not missing:
        return
    names = " and ".join(f"'{e}'" for e in missing)
    packages = ", ".join(EXTRA_MODULES[e] for e in missing)
    plural = "extras" if len(missing) > 1 else "extra"
    raise BackendNotAvailableError(f"{purpose}: needs the {names} {plural} ({packages}): "
                                   f"{install_hint(','.join(missing))}")
