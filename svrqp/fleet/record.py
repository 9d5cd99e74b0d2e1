"""One record's gap diagnosis from the options of ``svrqp gap``: the one code path of the command
and of every record of a fleet, so that a fleet's per-record JSON is the command's, byte for byte
(up to ``runtime_s``, the seconds the diagnosis took).

:class:`GapOptions` holds the options as the command line gives them (column lists as
comma-separated text); :func:`question_for` checks them against a table and builds the
:class:`~svrqp.gap.GapQuestion`; :func:`diagnose_table` runs it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from svrqp import registry
from svrqp.exceptions import ProblemError
from svrqp.tables import split_columns

if TYPE_CHECKING:
    import pandas as pd

    from svrqp.gap import GapQuestion, GapReport

#: The options a fleet's manifest may set per record (the others are the fleet's).
PER_RECORD = ("target", "train", "features", "model", "prediction", "candidates", "order",
              "group")


@dataclass(frozen=True)
class GapOptions:
    """The options of ``svrqp gap`` that decide its answer, as its command line spells them.

    ``features``, ``candidates`` and ``local_along`` are comma-separated column names; ``model``
    None means the first baseline of :mod:`svrqp.registry`. ``jobs`` (threads) does not change the
    answer and is not part of :meth:`key`.
    """

    target: str
    train: str
    candidates: str
    features: str | None = None
    model: str | None = None
    prediction: str | None = None
    order: str | None = None
    group: str | None = None
    seed: int = 0
    within_evidence: bool = False
    surrogates: str = "rotation"
    local: bool = False
    local_along: str | None = None
    jobs: int = 1

    def __post_init__(self) -> None:
        if (self.features is None) == (self.prediction is None):
            raise ProblemError("give exactly one of --features (a model is fitted) or "
                               "--prediction (a column)")
        if self.prediction is not None and self.model is not None:
            raise ProblemError(
                "--model applies to --features only; with --prediction nothing is fitted"
            )

    def key(self) -> dict[str, Any]:
        """Every setting that decides the answer: what a resumed fleet compares."""
        settings = dataclasses.asdict(self)
        settings.pop("jobs")
        return settings


def options_for(defaults: dict[str, Any], overrides: dict[str, Any], where: str) -> GapOptions:
    """The options of one record: the fleet's ``defaults`` with its manifest row's ``overrides``.

    A record's own ``features`` replace a fleet's ``prediction`` (and the other way round), so a
    manifest can mix the two modes. A record left without ``target``, ``train`` or
    ``candidates`` is refused with ``where`` (the manifest row) in the message.
    """
    unknown = sorted(set(overrides) - set(PER_RECORD))
    if unknown:
        raise ProblemError(f"{where}: a record may set only {', '.join(PER_RECORD)}; got {unknown}")
    values = {k: v for k, v in defaults.items() if v is not None}
    own = {k: v for k, v in overrides.items() if v is not None}
    if "features" in own:
        values.pop("prediction", None)
    if "prediction" in own:
        values.pop("features", None)
        values.pop("model", None)
    values.update(own)
    missing = [f"--{k}" for k in ("target", "train", "candidates") if not values.get(k)]
    if missing:
        raise ProblemError(f"{where}: no {', '.join(missing)} (give it as an option of the fleet "
                           f"or in the manifest)")
    try:
        return GapOptions(**values)
    except (ProblemError, TypeError) as err:
        raise ProblemError(f"{where}: {err}") from None


def _one(text: str | None, table: pd.DataFrame, option: str) -> str | None:
    """The single column named by an option (None when the option was not given)."""
    names = split_columns(text, table, option)
    if text is not None and len(names) != 1:
        raise ProblemError(f"{option}: name exactly one column, got {text!r}")
    return names[0] if names else None


def question_for(table: pd.DataFrame, options: GapOptions) -> GapQuestion:
    """The question ``options`` ask of ``table``, each column checked to be in it."""
    from svrqp.gap import GapQuestion

    return GapQuestion(
        target=_one(options.target, table, "--target"),
        train=options.train,
        features=split_columns(options.features, table, "--features") or None,
        prediction=_one(options.prediction, table, "--prediction"),
        candidates=split_columns(options.candidates, table, "--candidates"),
        order=_one(options.order, table, "--order"),
        group=_one(options.group, table, "--group"),
        model=registry.baselines()[0] if options.model is None else options.model,
        local=options.local,
        local_along=split_columns(options.local_along, table, "--local-along") or None,
    )


def diagnose_table(table: pd.DataFrame, options: GapOptions,
                   progress: Callable[[str, float], None] | None = None,
                   pool: bool = False) -> GapReport:
    """The diagnosis ``svrqp gap`` makes of ``table`` with ``options``; with ``pool`` (a fleet's
    record), also every candidate's transfer-test p-value, ``report.pool_p``
    (:mod:`svrqp.gap.transfer.pooling`: after the diagnosis, on its own stream, the JSON
    unchanged)."""
    from svrqp.gap import diagnose

    return diagnose(table, question_for(table, options), seed=options.seed,
                    surrogates=options.surrogates, n_jobs=options.jobs,
                    within_evidence=options.within_evidence, progress=progress, pool=pool)
