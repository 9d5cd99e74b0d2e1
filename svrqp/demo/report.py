"""``report.html`` of ``svrqp demo``: the numbers of ``results.json`` with links to every file."""

from __future__ import annotations

import html
from typing import Any

from svrqp.demo.vocabulary import COLUMNS, cells, rule_text

SIMULATED_NOTE = ("All data in this demo are SIMULATED by svrqp.machine (the embedded datasets), "
                  "imitating the papers' set-ups; they are not the papers' measurements, so our "
                  "numbers are not expected to equal the published ones.")


QUICK_NOTE = "Quick run (--quick): smaller S0 CV grid and S1 GA. "


def _table(header: list[str], rows: list[list[Any]]) -> str:
    def cell(value: Any) -> str:
        if value is None:
            return "—"
        return f"{value:.4g}" if isinstance(value, float) else html.escape(str(value))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _link(path: str, text: str | None = None) -> str:
    return f'<a href="{html.escape(path)}">{html.escape(text or path)}</a>'


def _figure(path: str, caption: str) -> str:
    return (f'<figure><a href="{html.escape(path)}"><img src="{html.escape(path)}" '
            f'alt="{html.escape(caption)}" '
            f'width="640"></a><figcaption>{html.escape(caption)}</figcaption></figure>')


def _s0_table(table: list[dict[str, Any]]) -> str:
    rows = [[r["model"], r["batch"], r["rms_um"], r["paper_rms_um"], r["std_um"],
             r["max_abs_um"]] for r in table]
    return _table(["model", "batch", "RMS of residual (μm)", "S0's published RMS (μm)",
                   "std of residual, mean removed (μm)", "max |residual| (μm)"], rows)


def _paragraphs(sentences: list[str]) -> str:
    return "".join(f"<p>{html.escape(sentence)}</p>" for sentence in sentences)


def _s0(s0: dict[str, Any]) -> str:
    best = s0["cv"]["best_params"]
    variant = s0["absolute_variant"]
    return ("<h2>S0 — spindle thermal error: MLR vs ε-SVR (fit on x1)</h2><p>Data: "
            f"<code>{html.escape(s0['dataset'])}</code>, S0's set-up — temperature rises from the "
            "start of each run and the probe zeroed at the start; inputs "
            f"{', '.join(s0['features'])}.</p><p>ε-SVR: RBF kernel, ε = {s0['epsilon_um']} μm "
            f"fixed; {s0['cv']['folds']}-fold CV over C ∈ {s0['cv']['grid']['C']}, γ ∈ "
            f"{s0['cv']['grid']['gamma']} chose C = {best['C']:g}, γ = g = {best['gamma']:g} (CV "
            f"MSE {s0['cv']['best_mse_um2']:.4g} μm²); {s0['n_support']} support vectors (S0: 56). "
            f"MLR: {html.escape(s0['mlr_formula'])}.</p><p>Metric: {html.escape(s0['metric'])}.</p>"
            + _s0_table(s0["table"])
            + f"<p>{html.escape(s0['sentence'])}</p>" + _paragraphs(s0["extrapolation"])
            + "".join(_figure(path,
                              f"S0 batch {batch}: measured vs predicted vs residual over time")
                      for batch, path in s0["figures"].items())
            + f"<p>Per-sample predictions: {_link(s0['predictions'])}; CV grid: "
              f"{_link(s0['cv_table'])}.</p>"
            + _contiguous(s0["contiguous_folds_variant"])
            + "<h3>Variant: absolute temperatures "
              f"(<code>{html.escape(variant['dataset'])}</code>)</h3><p>The same pipeline on "
              f"absolute temperatures {', '.join(variant['features'])}, with the error counted "
              "from the machine at 20 °C: not S0's set-up, kept to show what extrapolation does. "
              f"MLR: {html.escape(variant['mlr_formula'])}; ε-SVR C = "
              f"{variant['best_params']['C']:g}, γ = {variant['best_params']['gamma']:g}.</p>"
            + _s0_table(variant["table"]) + _paragraphs(variant["extrapolation"]))


def _contiguous(variant: dict[str, Any]) -> str:
    best = variant["best_params"]
    return ("<h3>Variant: contiguous CV folds</h3><p>S0 splits its folds at random, as the "
            f"table above does; with {html.escape(variant['folds'])} the CV chooses C = "
            f"{best['C']:g}, γ = {best['gamma']:g}:</p>" + _s0_table(variant["table"]))


def _s1(s1: dict[str, Any]) -> str:
    genetic, best, paper = s1["genetic"], s1["best_params"], s1["paper"]
    size = (f"population {genetic['population']}, {genetic['generations']} generations, "
            f"Pc = {genetic['crossover_probability']}, Pm = {genetic['mutation_probability']}")
    quick = " This quick run shrinks S1's GA (100 × 50)." if s1["quick"] else ""
    edge = (f" {s1['edge_text'][:1].upper()}{s1['edge_text'][1:]}." if s1["edge_text"]
            else " No parameter ended on a bound.")
    return ("<h2>S1 — GA-tuned ε-SVR (Chen &amp; Gong 2012)</h2><p>Data: "
            f"<code>{html.escape(s1['dataset'])}</code>, inputs {', '.join(s1['features'])} "
            f"(standardised). GA over C ∈ {s1['ranges']['C']} and ε ∈ {s1['ranges']['epsilon']} μm "
            f"(genes: their logarithms), γ fixed: {size}.{quick} It chose C = {best['C']:.4g}, "
            f"ε = {best['epsilon']:.3g} μm (S1: {paper['C']}, {paper['epsilon']}); "
            f"{s1['n_support']} of {s1['n_train']} training samples are support vectors.{edge}</p>"
            + _table(["", "Σ|r| on test (μm)", "S1"],
                     [["untuned SVR (C = 1, ε = 0.5)", s1["sum_abs_um"]["untuned"],
                       paper["sum_abs_untuned_um"]],
                      ["GA-SVR", s1["sum_abs_um"]["ga"], paper["sum_abs_ga_um"]]]))


def _s3(s3: dict[str, Any]) -> str:
    ours, paper = s3["ours"], s3["paper"]
    return ("<h2>S3 — recursive least squares on-line (Yang)</h2><p>Both models start from the "
            f"first {s3['start_workpieces']} workpieces of <code>{html.escape(s3['dataset'])}"
            "</code>; the recursive one predicts each next workpiece before absorbing it.</p>"
            + _table(["model", "max |r| (μm)", "mean |r| (μm)", "S3 max", "S3 mean"],
                     [["static LS", ours["static_max_um"], ours["static_mean_um"],
                       paper["static_max_um"], paper["static_mean_um"]],
                      ["RLS", ours["rls_max_um"], ours["rls_mean_um"], paper["rls_max_um"],
                       paper["rls_mean_um"]]]))


def _s4(s4: dict[str, Any]) -> str:
    paper = s4["paper"]
    unseen = ", ".join(str(run) for run in s4["test_runs"])
    rows = [[f"straightness before (μm, mean of runs {unseen})", s4["before_um"],
             paper["before_um"]],
            ["after compensation (μm)", s4["after_um"], paper["after_um"]],
            ["improvement (%)", s4["improvement_percent"], paper["improvement_percent"]]]
    per_run = [[run["run"], "fitted on (in sample)" if run["fitted_on"] else "unseen",
                run["before_um"],
                run["after_um"], run["improvement_percent"]] for run in s4["runs"]]
    return ("<h2>S4 — LS-SVR straightness compensation (out of sample)</h2><p>LS-SVR with S4's σ "
            f"= {s4['sigma_mm']} mm (2σ² convention, γ = {s4['gamma']:.4g}) and C = {s4['C']}, "
            f"{s4['n_support']} support vectors, fitted on run {s4['train_run']}; output = window "
            f"mean over the next {s4['feed_forward_mm']} mm with a {s4['dead_band_um']} μm dead "
            f"band (S4 eq. 8), applied to runs {unseen}, which the model never saw.</p><p>Metric: "
            f"{html.escape(s4['metric'])}.</p>"
            + _table(["", "unseen runs", "S4"], rows)
            + _table(["run", "role", "before (μm)", "after (μm)", "improvement (%)"], per_run)
            + _figure(s4["figure"], "S4 straightness of an unseen run before and after"))


def _s2(s2: dict[str, Any]) -> str:
    components = list(s2["max_error_improved"])
    rows = [[c, s2["max_error_improved"][c], s2["max_error_original"][c]] for c in components]
    mse = s2["mse_um2"]
    paper = s2["paper"]
    return ("<h2>S2 — nine-line identification and δx(x) models</h2><p>Largest error of the "
            "identified components against the simulator's truth (μm for δ, μrad for θ):</p>"
            + _table(["component", "improved method", "original method"], rows)
            + f"<p>{html.escape(s2['identification_note'])}</p>"
            + f"<p>δx(x): ε-SVR (5-fold CV: C = {s2['svr_params']['C']:g}, γ = "
              f"{s2['svr_params']['gamma']:.4g} "
              f"on u = x/550; {s2['n_support']} SVs) vs 5th-order least-squares polynomial.</p>"
            + _table(["MSE (μm²)", "ε-SVR", "5th-order LSM"],
                     [["fit (as S2 reports)", mse["svr_fit"], mse["lsm_fit"]],
                      ["leave-one-out", mse["svr_loo"], mse["lsm_loo"]],
                      ["S2 published (fit)", paper["mse_svr"], paper["mse_lsm"]]])
            + f"<p>Metric: {html.escape(s2['metric'])}. {html.escape(s2['variant_note'])}</p>"
            + _figure(s2["figure"], "S2 δx identification and models"))


def _export(export: dict[str, Any]) -> str:
    verify = export["verify"]
    checks = [[c["name"], "OK" if c["ok"] else "FAIL", c["detail"]] for c in verify["checks"]]
    cross = export["cross_check"]
    return ("<h2>Export of S0's ε-SVR</h2><p>"
            + ", ".join(_link(path) for path in export["files"])
            + f"</p><p>svrqp verify: <b>{'OK' if verify['ok'] else 'FAIL'}</b></p>"
            + _table(["check", "result", "detail"], checks)
            + f"<p>Cross-check against {html.escape(cross['reference'])}: max |Δprediction| = "
              f"{cross['max_abs_deviation']:.3g} μm (std of the target {cross['target_std']:.3g} "
              f"μm).</p>")


def verdict_label(verdict: dict[str, Any]) -> str:
    """The gap verdict in a few words: the named effect, or why none is named."""
    if verdict.get("column"):
        return f"{verdict['column']} ({verdict.get('transform')})"
    if verdict.get("ambiguous_with"):
        return "none named — several candidates cannot be told apart"
    return "no cause beyond chance"


def _gap(gap: dict[str, Any]) -> str:
    return ("<h2>Gap diagnosis: why the summer MLR on absolute temperatures misses "
            "autumn</h2><p>Run on the absolute variant (<code>miao2013</code>, inputs T7_C and "
            "T9_C), where the summer model is used far outside its training range in "
            f"autumn.</p><p>Verdict: <b>{html.escape(verdict_label(gap['verdict']))}</b>"
            + f"</p><p>{html.escape(gap['summary'])}</p>"
            + f"<p>Full report: {_link(gap['html'])}; JSON: {_link(gap['json'])}.</p>")


def _reproduction(rows: list[dict[str, Any]]) -> str:
    return ("<h2>Reproduction, seed by seed</h2><p>The papers' numbers against ours on the "
            "simulated data, each with its metric and tolerance; where ours is not reproduced, "
            f"the measured reason. {html.escape(rule_text())}</p>"
            + _table([*COLUMNS, "why"], [[*cells(r), r["note"]] for r in rows]))


def report_html(results: dict[str, Any]) -> str:
    """The demo's report page (figures and exported files are linked by relative paths)."""
    sections = [_reproduction(results["reproduction"]), _s0(results["s0"]), _s1(results["s1"]),
                _s4(results["s4"]), _s2(results["s2"]), _s3(results["s3"]),
                _export(results["export"])]
    if results.get("gap") is not None:
        sections.append(_gap(results["gap"]))
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>svrqp demo</title>"
            "<style>body{font-family:sans-serif;max-width:60em;margin:auto}table{border-collapse:collapse}"
            "td,th{border:1px solid #bbb;padding:2px "
            "8px;text-align:right}td:last-child{text-align:left}</style></head><body>"
            f"<h1>svrqp demo</h1><p><b>{html.escape(SIMULATED_NOTE)}</b></p>"
            f"<p>{QUICK_NOTE if results['quick'] else ''}"
            f"Run time {results['runtime_s']:.1f} s; numbers in {_link('results.json')}.</p>"
            + "".join(sections) + "</body></html>\n")
