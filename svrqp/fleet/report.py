"""The fleet's HTML page: one self-contained file with its figures embedded as PNG.

Four panels (:func:`fleet_figure`): how often each effect is named (by the records' own verdicts,
and which the pooled evidence names), the distribution of the named causes' shrinks, the inputs
used outside their train range (how many records), and the slowest records. Below them, the
pooled table, the failed records with their reasons, and the fleet table. matplotlib is imported
when the figure is drawn, never with this module, and only as ``Figure`` objects (pyplot's
backend is left alone).
"""

from __future__ import annotations

import base64
import html
import io
from collections import Counter

import pandas as pd

from svrqp.fleet.pooled import PooledVerdict

SLOWEST = 10


def fleet_figure(table: pd.DataFrame, pooled: PooledVerdict) -> bytes:
    """The four panels of the page, as PNG bytes."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(11, 7.5), layout="constrained")
    (named, shrinks), (extrapolated, slow) = fig.subplots(2, 2)
    ok = table[table["status"] != "failed"]
    counts = Counter(c or "(none)" for c in ok["verdict_column"])
    labels = sorted(counts, key=lambda c: (-counts[c], c))
    colours = ["tab:red" if c in pooled.named else "tab:blue" for c in labels]
    named.bar(labels, [counts[c] for c in labels], color=colours)
    named.set_title("Effects named by the records (red: also named by the pooled evidence)")
    named.set_ylabel("records")
    named.tick_params(axis="x", labelrotation=30)
    values = ok["shrink"].dropna().astype(float)
    shrinks.hist(values, bins=min(20, max(len(values), 1)), color="tab:green")
    shrinks.set_title(f"Shrink of the named cause ({len(values)} records)")
    shrinks.set_xlabel("shrink (1 − RMSE after / RMSE before)")
    shrinks.set_ylabel("records")
    inputs = Counter(name for text in ok["extrapolated"] for name in str(text).split(",") if name)
    names = sorted(inputs, key=lambda c: (-inputs[c], c))
    extrapolated.barh(names or ["(none)"], [inputs[c] for c in names] or [0], color="tab:orange")
    extrapolated.set_title("Model inputs and candidates used outside their train range")
    extrapolated.set_xlabel("records")
    top = table.sort_values("runtime_s", ascending=False).head(SLOWEST)[::-1]
    slow.barh(top["name"], top["runtime_s"].astype(float), color="tab:gray")
    slow.set_title(f"Slowest {len(top)} records")
    slow.set_xlabel("runtime (s)")
    for ax in (named, shrinks):
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    extrapolated.xaxis.set_major_locator(MaxNLocator(integer=True))
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90)
    return buffer.getvalue()


def _html_table(frame: pd.DataFrame) -> str:
    return frame.to_html(index=False, na_rep="", float_format=lambda x: f"{x:.4g}",
                         border=0, classes="table", escape=True)


def fleet_html(table: pd.DataFrame, pooled: PooledVerdict, title: str = "Fleet gap diagnosis",
               figure: bytes | None = None) -> str:
    """The page as HTML text (``figure`` as given, or drawn by :func:`fleet_figure`)."""
    png = base64.b64encode(figure or fleet_figure(table, pooled)).decode("ascii")
    failed = table[table["status"] == "failed"][["name", "path", "reason"]]
    counts = table["status"].value_counts().to_dict()
    state = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    parts = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{len(table)} records: {html.escape(state)}.</p>",
        f"<p>{html.escape(pooled.summary())}</p>",
        f'<img alt="fleet figures" src="data:image/png;base64,{png}">',
        "<h2>Pooled evidence</h2>", _html_table(pooled.table),
    ]
    if not failed.empty:
        parts += ["<h2>Failed records</h2>", _html_table(failed)]
    parts += ["<h2>Records</h2>", _html_table(table.drop(columns=["sha256"]))]
    style = ("body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;font-size:"
             "90%}td,th{padding:2px 8px;border-bottom:1px solid #ddd}img{max-width:100%}")
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{style}</style></head><body>"
            + "\n".join(parts) + "</body></html>\n")
