"""The walk of ``X`` through ``EpsilonSVR.fit``: how often a fit goes back to a module it left.

Issue #35 measured the walk as "15 modules, 48 stays, 33 returns to a module already left; the
certificate module is entered 8 times" and asked for fewer than 33 returns. This script makes that
measure repeatable. It traces one ``EpsilonSVR(C, epsilon, gamma).fit(X, y)`` with the default
solver with :func:`sys.setprofile`, keeping the ``call`` events of Python frames whose module is
``svrqp`` or inside it (C functions and other packages are not steps of the walk). Consecutive
calls in the same module collapse into one *stay*; a *return* is a stay in a module the walk had
already left before. So ``returns = stays - modules``: a walk that never goes back has none.

The data are the benchmark panel's noisy sinc (:func:`epsilon_svr_panel.sinc`: 5 inputs uniform on
[-3, 3], the target the sinc of their radius plus noise, both standardised), ``n = 200``, with
``C = 10``, ``epsilon = 0.1`` and ``gamma = 0.5`` by default.

Run: ``python benchmarks/fit_walk.py [--n N] [--seed S] [--quiet]`` with the ``svrqp`` to measure
on ``PYTHONPATH`` (another checkout measures that checkout); it prints the stays in order, the
stays per module, and one line ``MODULES modules, STAYS stays, RETURNS returns``.
``benchmarks/results/fit_walk.md`` records the runs.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the panel's generators, beside this

from epsilon_svr_panel import sinc  # noqa: E402

PACKAGE = "svrqp"


def stays(run: Callable[[], object], package: str = PACKAGE) -> list[str]:
    """The modules of ``package`` that ``run()`` calls into, consecutive calls collapsed.

    Parameters
    ----------
    run : callable
        What is traced (called once, with no argument).
    package : str
        Top-level package whose modules count.

    Returns
    -------
    list of str
        One dotted module name per stay, in the order of the walk.
    """
    walk: list[str] = []

    def profile(frame, event, arg):  # noqa: ARG001 (sys.setprofile's signature)
        if event != "call":
            return
        module = frame.f_globals.get("__name__", "")
        if (module == package or module.startswith(package + ".")) and (
            not walk or walk[-1] != module
        ):
            walk.append(module)

    previous = sys.getprofile()
    sys.setprofile(profile)
    try:
        run()
    finally:
        sys.setprofile(previous)
    return walk


def returns(walk: list[str]) -> int:
    """Stays in a module the walk had already left (``len(walk)`` less the modules visited)."""
    return len(walk) - len(set(walk))


def fit_walk(
    n: int = 200, seed: int = 0, C: float = 10.0, epsilon: float = 0.1, gamma: float = 0.5
) -> list[str]:
    """The stays of one default ``EpsilonSVR(C, epsilon, gamma).fit`` on the panel's sinc data."""
    from svrqp import EpsilonSVR

    X, y = sinc(n, seed)
    model = EpsilonSVR(C=C, epsilon=epsilon, gamma=gamma)
    EpsilonSVR(C=C, epsilon=epsilon, gamma=gamma).fit(X[:20], y[:20])  # imports done before
    return stays(lambda: model.fit(X, y))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="rows of the sinc data (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sinc data (default 0)")
    parser.add_argument("--quiet", action="store_true", help="print the summary line only")
    args = parser.parse_args(argv)
    walk = fit_walk(args.n, args.seed)
    if not args.quiet:
        seen: set[str] = set()
        for i, module in enumerate(walk, 1):
            mark = "  (return)" if module in seen else ""
            seen.add(module)
            print(f"{i:3d} {module}{mark}")
        print()
        for module, count in Counter(walk).most_common():
            print(f"{count:3d} stays  {module}")
        print()
    print(f"{len(set(walk))} modules, {len(walk)} stays, {returns(walk)} returns")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
