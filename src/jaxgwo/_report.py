"""Self-contained HTML reports of an identification or a diagnosis.

One file, no external resources: the figures are PNGs embedded as base64 ``data:`` URIs, the
style sheet is inline, and a Content-Security-Policy forbids loading anything else, so the
report reads the same offline, attached to an e-mail or archived.  Every piece of text is
HTML-escaped (file names and metadata can hold ``<`` or ``&``).

* :func:`identification_report_html` / :func:`write_identification_report` -- per channel:
  the parameters with Cramer-Rao bounds and insensitivities, the CIFER cost ``J`` (and the
  WLS start's), the validation R^2 / TIC / RMS, the transfer function; Bode, convergence and
  validation figures.
* :func:`diagnosis_report_html` / :func:`write_diagnosis_report` -- the diagnosis summary,
  verdict, the nominal fit, where the gap lies, the candidate ranking; the figure of
  :func:`jaxgwo._diagnose.plot_diagnosis`.
"""

from __future__ import annotations

import base64
import datetime
import html
import math
import os
import tempfile
from collections.abc import Mapping, Sequence

from ._atomic import atomic_write_text

__all__ = [
    "diagnosis_report_html",
    "identification_report_html",
    "write_diagnosis_report",
    "write_identification_report",
]

_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:2em auto;max-width:1200px;
color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
h3{font-size:1.05em}
table{border-collapse:collapse;margin:.6em 0 1em}th,td{border:1px solid #ccc;padding:.25em .6em;
text-align:right;font-variant-numeric:tabular-nums}th{background:#f2f2f2}
td.l,th.l{text-align:left}.meta{color:#555;font-size:.9em}.verdict{font-size:1.1em;font-weight:600}
img{max-width:100%;height:auto;border:1px solid #ddd}code,pre{background:#f6f6f6;padding:.1em .3em}
pre{padding:.6em;white-space:pre-wrap}.ok{color:#1a7f37}.no{color:#888}
"""
# nothing but inline style and data: images may load; the report cannot reach the network
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"


_LEFT = ' class="l"'


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _fmt(x, spec: str = ".4g") -> str:
    if x is None:
        return "&ndash;"
    if isinstance(x, bool):
        return "yes" if x else "no"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return _e(x)
    if not math.isfinite(v):
        return _e(str(v))
    return _e(format(int(v), spec) if spec.endswith("d") else format(v, spec))


def _label(key: str) -> str:
    """``bands_hz`` -> ``bands (Hz)``, ``peak_lag_s`` -> ``peak lag (s)``."""
    for suffix, unit in (("_hz", "Hz"), ("_s", "s")):
        if key.endswith(suffix):
            return f"{key[:-len(suffix)].replace('_', ' ')} ({unit})"
    return key.replace("_", " ")


def _cell(v) -> str:
    """A JSON value as table-cell HTML: frequency bands ``[[lo, hi], ...]`` as ranges."""
    if isinstance(v, list):
        if not v:
            return "none"
        if all(isinstance(x, (list, tuple)) and len(x) == 2 for x in v):
            return ", ".join(f"{_fmt(a, '.3g')}&ndash;{_fmt(b, '.3g')}" for a, b in v)
        return _e(", ".join(map(str, v)))
    if isinstance(v, str):
        return _e(v)
    return _fmt(v, ".4g")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1,
           cls: str = "") -> str:
    """``rows`` hold already-escaped cell HTML; the first ``left`` columns align left."""
    def cells(tag, row):
        return "".join(f"<{tag}{_LEFT if i < left else ''}>{c}</{tag}>" for i, c in enumerate(row))

    head = f"<tr>{cells('th', [_e(h) for h in header])}</tr>"
    body = "".join(f"<tr>{cells('td', r)}</tr>" for r in rows)
    c = f' class="{_e(cls)}"' if cls else ""
    return f"<table{c}><thead>{head}</thead><tbody>{body}</tbody></table>"


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<p><img alt="{_e(alt)}" src="data:image/png;base64,{data}"></p>'


def _page(title: str, body: str) -> str:
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<meta http-equiv=\"Content-Security-Policy\" content=\"{_CSP}\">"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n{body}\n</body></html>\n"
    )


def _meta_line(items: Mapping[str, object]) -> str:
    from . import __version__

    items = dict(items)
    items.setdefault("jaxgwo", __version__)
    items.setdefault("written",
                     datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"))
    return '<p class="meta">' + " &middot; ".join(
        f"{_e(k)}: {_e(v)}" for k, v in items.items() if v is not None) + "</p>"


# ----------------------------------------------------------------------------- identification


def _poly(coeffs) -> str:
    import numpy as np

    c = np.asarray(coeffs, dtype=float)
    n = c.size - 1
    terms = []
    for i, a in enumerate(c):
        p = n - i
        s = "" if p == 0 else ("s" if p == 1 else f"s^{p}")
        terms.append(f"{a:.6g}" + (f" {s}" if s else ""))
    return " + ".join(terms).replace("+ -", "- ")


def identification_report_html(results: Mapping | Sequence, *, source: str = "",
                               wall_s: float | None = None, command: str | None = None,
                               figures: bool = True) -> str:
    """The HTML report of :func:`jaxgwo.identify_channels` results (``{channel: result}``
    or a sequence of :class:`jaxgwo.ChannelIdentification`)."""
    res = list(results.values()) if isinstance(results, Mapping) else list(results)
    if not res:
        raise ValueError("no identification results to report.")
    parts = ["<h1>jaxgwo identification report</h1>",
             _meta_line({"data": source or None, "command": command,
                         "wall time": None if wall_s is None else f"{wall_s:.2f} s"})]
    rows = []
    for r in res:
        v = r.validation
        rows.append([_e(r.channel), _e(r.method), _fmt(r.seed, "d"), _fmt(r.cost_J, ".4g"),
                     _fmt(r.wls_cost_J, ".4g"), _fmt(int(r.response.n_passing), "d"),
                     _fmt(r.evaluations, "d"), _fmt(r.runtime_s, ".3g"),
                     _fmt(None if v is None else v.r2, ".4f"),
                     _fmt(None if v is None else v.tic, ".4f"),
                     _fmt(None if v is None else v.rms, ".4g")])
    parts.append("<h2>Summary</h2>")
    parts.append(_table(["channel", "method", "seed", "J", "WLS start J", "frequencies used",
                         "evaluations", "optimiser time (s)", "validation R²", "TIC",
                         "RMS (rad/s)"], rows, left=2))
    parts.append('<p class="meta">J: the CIFER cost 20/n &Sigma; W [(dB error)² + 0.01745 '
                 "(deg error)²] over the frequencies with coherence above the threshold; "
                 "R² and TIC on held-out records the model was not fitted to.</p>")
    from ._export import _UNITS

    for r in res:
        parts.append(f"<h2>{_e(r.channel)} channel</h2>")
        unc = r.uncertainty.as_dict()
        units = _UNITS["paper"]
        prow = [[_e(name), _fmt(d["value"], ".6g"), _fmt(d["cr_percent"], ".3g"),
                 _fmt(d["insensitivity_percent"], ".3g"), _e(units.get(name, ""))]
                for name, d in unc.items()]
        parts.append(_table(["parameter", "value", "Cramér-Rao bound (%)",
                             "insensitivity (%)", "unit"], prow))
        parts.append("<p>G(s) = (" + _e(_poly(r.model.numerator)) + ") / ("
                     + _e(_poly(r.model.denominator)) + ")</p>")
        if r.validation is not None and len(r.validation.per_record_r2) > 1:
            parts.append("<p>validation R² per record: " + ", ".join(
                _fmt(x, ".4f") for x in r.validation.per_record_r2) + "</p>")
    if figures:
        from ._plots import (
            ConvergenceBand,
            bode_figure,
            convergence_figure,
            figure_png,
            validation_figure,
        )

        parts.append("<h2>Figures</h2>")
        parts.append("<h3>Bode</h3>")
        parts.append(_img(figure_png(bode_figure(res)), "Bode plot of the measured and "
                          "identified responses"))
        panels = {f"{r.channel}": {f"{r.method}, seed {r.seed}":
                                   ConvergenceBand.from_histories(r.convergence)}
                  for r in res if len(r.convergence)}
        if panels:
            parts.append("<h3>Convergence</h3>")
            parts.append(_img(figure_png(convergence_figure(panels, ylabel="best J")),
                              "convergence of the best cost"))
        if any(r.validation is not None for r in res):
            parts.append("<h3>Time-domain validation</h3>")
            parts.append(_img(figure_png(validation_figure(res)),
                              "measured and simulated rates on the validation records"))
    return _page("jaxgwo identification report", "\n".join(parts))


def write_identification_report(results, path: str | os.PathLike, **kw) -> str:
    """:func:`identification_report_html`, written atomically to ``path``."""
    atomic_write_text(path, identification_report_html(results, **kw))
    return os.fspath(path)


# ----------------------------------------------------------------------------- diagnosis


def _diagnosis_png(d) -> bytes | None:
    from ._diagnose import plot_diagnosis

    with tempfile.TemporaryDirectory(prefix="jaxgwo-report-") as tmp:
        path = os.path.join(tmp, "diagnosis.png")
        plot_diagnosis(d, path)
        with open(path, "rb") as fh:
            return fh.read()


def diagnosis_report_html(d, *, source: str = "", command: str | None = None,
                          figures: bool = True) -> str:
    """The HTML report of a :func:`jaxgwo._diagnose.diagnose` result: summary, verdict,
    nominal fit and its time-domain null refit, where the gap lies, the candidate ranking
    and the diagnosis figure."""
    doc = d.to_json()
    parts = [f"<h1>jaxgwo diagnosis report: {_e(doc.get('channel', ''))} channel</h1>",
             _meta_line({"data": source or None, "command": command})]
    verdict = doc.get("verdict")
    parts.append(f'<p class="verdict">Verdict: {_e(verdict)}</p>')
    parts.append("<pre>" + _e(d.summary()) + "</pre>")
    nom = doc.get("nominal", {})
    parts.append("<h2>Nominal model</h2>")
    prow = [[_e(k), _fmt(v, ".6g")] for k, v in (nom.get("params") or {}).items()]
    prow += [[_e("J"), _fmt(nom.get("cost_J"), ".4g")],
             [_e("validation R²"), _fmt(nom.get("val_r2"), ".4f")],
             [_e("validation TIC"), _fmt(nom.get("val_tic"), ".4f")]]
    parts.append(_table(["quantity", "value"], prow))
    ref = doc.get("time_domain_refit")
    if ref:
        parts.append("<h2>Null refit: the nominal refitted by output error, no effect added</h2>")
        rrow = [[_e(k), _fmt(v, ".6g")] for k, v in (ref.get("params") or {}).items()]
        rrow += [[_e("identification output error (mean square)"), _fmt(ref.get("train_mse"), ".4g")],
                 [_e("validation R²"), _fmt(ref.get("val_r2"), ".4f")],
                 [_e("validation TIC"), _fmt(ref.get("val_tic"), ".4f")],
                 [_e("gap closed"), _fmt(ref.get("gap_closed"), ".3f")]]
        parts.append(_table(["quantity", "value"], rrow))
    where = doc.get("where", {})
    parts.append("<h2>Where the model departs</h2>")
    wrows = [[_e(_label(k)), _cell(v)] for k, v in where.items()]
    parts.append(_table(["test", "result"], wrows, left=2))
    parts.append("<h2>Candidate ranking</h2>")
    st = doc.get("structure")
    if st:
        parts.append("<p>Ranked on top of the structure finding, an extra pole pair at "
                     + _fmt((st.get("params") or {}).get("freq_hz"), ".3g") + " Hz (held-out R² "
                     + _fmt(st.get("val_r2"), ".4f") + "); each gap closed is of the gap it leaves.</p>")
    crows = []
    for i, c in enumerate(doc.get("ranking", []), start=1):
        params = ", ".join(f"{k} = {_fmt(v, '.4g')} &plusmn; "
                           f"{_fmt((c.get('params_sigma') or {}).get(k), '.2g')}"
                           for k, v in (c.get("params") or {}).items())
        beats = c.get("beats_noise")
        crows.append([_fmt(i, "d"), _e(c.get("effect", "")), params or "&ndash;",
                      _fmt(c.get("val_r2"), ".4f"), _fmt(c.get("gap_closed"), ".3f"),
                      _fmt(c.get("z_score"), ".3g"), _fmt(c.get("delta_bic"), ".4g"),
                      _fmt(c.get("signature_agreement"), ".2f"),
                      f'<span class="{"ok" if beats else "no"}">{_fmt(bool(beats))}</span>'])
    parts.append(_table(["rank", "effect", "parameters", "validation R²", "gap closed", "z",
                         "ΔBIC", "signature agreement", "beats noise"], crows, left=3))
    comb = doc.get("combined_top2")
    if comb:
        parts.append("<p>Top two combined (" + _e(" + ".join(comb.get("effects", []))) + "): R² "
                     + _fmt(comb.get("val_r2"), ".4f") + ", gap closed "
                     + _fmt(comb.get("gap_closed"), ".3f") + "</p>")
    skipped = doc.get("skipped") or {}
    if skipped:
        parts.append("<h3>Skipped candidates</h3><ul>" + "".join(
            f"<li>{_e(k)}: {_e(v)}</li>" for k, v in skipped.items()) + "</ul>")
    if doc.get("suggestion"):
        parts.append(f"<p><b>Suggestion:</b> {_e(doc['suggestion'])}</p>")
    if figures:
        png = _diagnosis_png(d)
        if png:
            parts.append("<h2>Figure</h2>")
            parts.append(_img(png, "diagnosis: Bode mismatch, residual tests, overlays, "
                                   "candidate gains"))
    return _page(f"jaxgwo diagnosis report ({doc.get('channel', '')})", "\n".join(parts))


def write_diagnosis_report(d, path: str | os.PathLike, **kw) -> str:
    """:func:`diagnosis_report_html`, written atomically to ``path``."""
    atomic_write_text(path, diagnosis_report_html(d, **kw))
    return os.fspath(path)
