"""The gap report in words: Markdown and HTML renderings of a diagnosis, its tables, and its writer.

:class:`GapReport` is the data of :class:`svrqp.gap.results.document.GapResult` with its
renderings. Nothing is written that fails the schema (the JSON is validated first), and no
file is overwritten unless ``force=True``; every file goes through :mod:`svrqp.output`, the writer
of every command (no symlink followed, no FIFO opened, nothing half-written).
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from svrqp import output
from svrqp.gap.results.document import GapResult
from svrqp.gap.words.figures import before_after_figure, gap_figure
from svrqp.gap.words.verdict import effect_label, interval_text
from svrqp.units import probability, unit_of

BOUND_DIGITS = 4
"""Significant digits of region bounds and input ranges
in the tables (close bounds such as 26.76 … 26.9 °C)."""
FIGURE_ALT = {"gap": "measured, model and residual", "before_after": "before and after"}
"""Alternative text of each report figure (keys of the figures dictionary)."""


@dataclass
class GapReport(GapResult):
    """Result of :func:`svrqp.gap.diagnose`: the data
    (:class:`svrqp.gap.results.document.GapResult`, with ``to_dict`` and ``to_json``) and its
    renderings: ``write_json``, ``to_markdown``, ``to_html`` and ``tables``.
    """

    def write_json(self, path: str | Path, force: bool = False) -> Path:
        """Write :meth:`to_json` to ``path`` (validated
        first; refuses to overwrite unless ``force``)."""
        return output.write_bytes(path, self.to_json().encode("utf-8"), force=force)

    def to_markdown(self, path: str | Path | None = None, force: bool = False) -> str:
        """The report as Markdown; with ``path``, also write it and its PNG figures beside it."""
        figures = self._figures()
        stem = "figure" if path is None else Path(path).stem
        names = {key: f"{stem}_{key}.png" for key in figures}
        text = self._markdown(names)
        if path is not None:
            path = Path(path)
            targets = [path, *(path.with_name(name) for name in names.values())]
            taken = [str(t) for t in targets if t.exists()]
            if taken and not force:
                raise FileExistsError(f"{taken} exist; pass force=True (--force) to overwrite them")
            for key, png in figures.items():
                output.write_bytes(path.with_name(names[key]), png, force=True)
            output.write_bytes(path, text.encode("utf-8"), force=True)
        return text

    def to_html(self, path: str | Path, force: bool = False) -> Path:
        """Write a self-contained HTML report (figures embedded) to ``path``."""
        return output.write_bytes(path, self._html().encode("utf-8"), force=force)

    # -- rendering ---------------------------------------------------------------------

    def _order_regions(self) -> list[tuple[float, float, str | None]]:
        return [(r.low, r.high, r.group) for r in self.where if r.column == self.order]

    def _figures(self) -> dict[str, bytes]:
        figures = {"gap": gap_figure(self.series, self._order_regions())}
        if self.verdict.column is not None and self.series.after is not None:
            # shaded where it is a stretch of the figure's axis, the order axis
            region = self.verdict.region
            along_order = region is not None and region["column"] == self.order
            figures["before_after"] = before_after_figure(self.series, effect_label(self.verdict),
                                                          (region["low"], region["high"])
                                                          if along_order else None)
        return figures

    def tables(self) -> dict[str, tuple[list[str], list[list[str]]]]:
        """The report's tables as text cells, as the Markdown and HTML reports print them.

        Returns
        -------
        dict
            ``"gap"``, ``"where"``, ``"causes"`` and ``"inputs"`` (no row in prediction mode),
            each ``(header, rows)``.
        """
        unit = unit_of(self.target)
        rmse = f"RMSE ({unit})" if unit else "RMSE"
        where = (["column", "run", "low", "high", rmse, "share", "share of its run", "n"],
                 [[r.column, "all" if r.group is None else r.group, _num(r.low, BOUND_DIGITS),
                   _num(r.high, BOUND_DIGITS), _num(r.rmse), share_text(r.share),
                   "–" if r.share_of_run is None else share_text(r.share_of_run), str(r.n)]
                  for r in self.where])
        causes = (["rank", "column", "transform", "τ", "q (transfer)", f"{rmse} after",
                   "shrink (95 % CI)", "beyond the refit", "per-run recalibration", "note"],
                  [[str(i + 1), c.column, c.transform, _num(c.tau), probability(c.p_value),
                    _num(c.rmse_after),
                    f"{c.shrink:.0%}{interval_text(c.shrink_ci, ' (', ')')}",
                    "–" if c.shrink_beyond_refit is None else f"{c.shrink_beyond_refit:.0%}",
                    "–" if c.within_shrink is None else f"{c.within_shrink:.0%}",
                    c.note or ("significant" if c.significant else "")]
                   for i, c in enumerate(self.causes)])
        # a kernel model: say which rows refit it
        if (self.transfer or {}).get("family", "linear") != "linear":
            causes = ([*causes[0][:-1], "refitted family", "note"],
                      [[*row[:-1], c.family, row[-1]]
                       for row, c in zip(causes[1], self.causes, strict=True)])
        g = self.gap
        gap = (["train RMSE", "real RMSE", "ratio", "p (excess over train)", "noise RMSE",
                "p (excess over noise)", "p (white residual)", "gap"],
               [[_num(g.train_rmse), _num(g.real_rmse), _num(g.ratio), _num(g.p_excess),
                 _num(g.noise_rmse), _num(g.p_noise), _num(g.p_white),
                 "detected" if self.gap_detected else "not detected"]])
        inputs = (["input", "role", "train range", "real range", "real rows outside",
                   "recalibration shrink", "beyond the offsets"],
                  [[u.column, u.role, _range(u.train_low, u.train_high, unit_of(u.column)),
                    _range(u.real_low, u.real_high, unit_of(u.column)),
                    share_text(u.outside), f"{u.recalibration_shrink:.0%}",
                    "–" if u.beyond_offsets is None else f"{u.beyond_offsets:.0%}"]
                   for u in self.inputs])
        return {"gap": gap, "where": where, "causes": causes, "inputs": inputs}

    def _inputs_sentence(self) -> str:
        """How to read the inputs table."""
        return ("The model's own inputs on the real rows: \"recalibration shrink\" is what offsets "
                "and that input alone, refitted on the real rows, remove of the error out of "
                "sample; \"beyond the offsets\" is that input's own part. An input outside its "
                "train range on most real rows whose recalibration removes much of the error is a "
                "model used beyond its data.")

    def _blocks(self, figures: Iterable[str]) -> list[tuple[str, str]]:
        """The report in reading order as ``(kind, content)`` blocks, which :meth:`_markdown` and
        :meth:`_html` render alike: ``title`` (the target), ``text``, ``heading``, ``table`` and
        ``figure`` (keys of :meth:`tables` and :meth:`_figures`)."""
        blocks = [("title", self.target), ("text", self.summary),
                  ("heading", "Gap"), ("table", "gap"), ("figure", "gap"),
                  ("heading", "Where"), ("table", "where"),
                  ("heading", "Causes"), ("text", self._base_sentence()), ("table", "causes")]
        if "before_after" in figures:
            blocks.append(("figure", "before_after"))
        if self.inputs:
            blocks += [("heading", "Model inputs"), ("text", self._inputs_sentence()),
                       ("table", "inputs")]
        return blocks + [("heading", "Verdict"), ("text", self.verdict.reason)]

    def _markdown(self, figure_names: dict[str, str]) -> str:
        tables = self.tables()
        render = {"title": lambda target: f"# Gap diagnosis of `{target}`", "text": str,
                  "heading": lambda title: f"## {title}",
                  "table": lambda key: markdown_table(*tables[key]),
                  "figure": lambda key: f"![{FIGURE_ALT[key]}]({figure_names[key]})"}
        return "\n\n".join(render[kind](content)
                           for kind, content in self._blocks(figure_names)) + "\n"

    def _base_sentence(self) -> str:
        """How to read the shrink columns: transfer numbers, and the per-run recalibration apart."""
        refit = self.transfer.get("shrink_refit")
        refit_text = "" if refit is None else f" (the refit alone: {refit:.0%})"
        return ("Each shrink is a transfer number: the model refitted leave-one-run-out over all "
                "rows with the effect added, scored on the real rows it never saw, against the "
                "given model's real-row error; \"beyond the refit\" is against the same refit "
                f"without the effect{refit_text}. \"per-run recalibration\" is what a discrepancy "
                "model fitted on the real rows themselves removes — the base alone "
                f"({self.base.description}) removes {self.base.shrink:.0%} — which no new run "
                "gets.")

    def _html(self) -> str:
        figures = self._figures()
        tables = self.tables()
        render = {"title": lambda target: f"<h1>Gap diagnosis of "
                                          f"<code>{html.escape(target)}</code></h1>",
                  "text": lambda text: f"<p>{html.escape(text)}</p>",
                  "heading": lambda title: f"<h2>{html.escape(title)}</h2>",
                  "table": lambda key: _html_table(*tables[key]),
                  "figure": lambda key: f'<img alt="{html.escape(FIGURE_ALT[key])}" '
                                        f'src="data:image/png;base64,{base64.b64encode(figures[key]).decode()}">'}
        parts = [render[kind](content) for kind, content in self._blocks(figures)]
        style = "body{font-family:sans-serif;max-width:60em;margin:2em auto}" \
                "table{border-collapse:collapse}" \
                "td,th{border:1px solid #ccc;padding:0.2em 0.5em}img{max-width:100%}"
        return "<!doctype html><html><head><meta charset='utf-8'><title>svrqp gap</title>" \
               f"<style>{style}</style></head>" \
               f"<body>{''.join(parts)}</body></html>"


def _num(x: float | None, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits; no exponent
    below a million (``2636``, not ``2.64e+03``)."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    text = f"{x:.{digits}g}"
    return f"{x:.0f}" if "e+" in text and abs(x) < 1e6 else text


def _range(low: float, high: float, unit: str | None) -> str:
    text = f"{_num(low, BOUND_DIGITS)} … {_num(high, BOUND_DIGITS)}"
    return f"{text} {unit}" if unit else text


def share_text(x: float) -> str:
    """A share (0 … 1) in percent; below 1 % with one significant digit, not rounded to 0 %.

    Parameters
    ----------
    x : float
        The share.

    Returns
    -------
    str
        E.g. ``"81%"``, ``"0.3%"``.
    """
    if 0 < x < 0.01:
        return f"{100 * x:.1g}%"
    return f"{x:.0%}"


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown pipe table of text cells (the format of :meth:`GapReport.to_markdown`)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _html_table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"
