"""HTML: tables, the page, and the parts every report shares (verdict, provenance, parameters)."""

from __future__ import annotations

import base64
import html
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..outputs import to_jsonable

__all__ = ["html_table", "html_page", "json_dumps", "verdict_banner", "provenance_table",
           "parameter_table", "number"]


def number(value: Any, spec: str = ".3f") -> str:
    """A number for a report cell: "–" where it is absent (None) or not finite.

    Parameters
    ----------
    value : float or None
    spec : str
        The format specification.

    Returns
    -------
    str

    Examples
    --------
    >>> number(0.01234), number(None), number(float("nan"), ".1f")
    ('0.012', '–', '–')
    """
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return format(value, spec)


def html_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
               headers: Sequence[str] | None = None, digits: int = 3) -> str:
    """An HTML table of ``rows`` (dicts) with the given columns.

    Parameters
    ----------
    rows : sequence of mapping
    columns : sequence of str
    headers : sequence of str, optional
    digits : int
        Decimals of floats.

    Returns
    -------
    str
    """
    def fmt(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, bool):  # a setting or a property, not a verdict (verdicts are words)
            return "yes" if v else "no"
        if isinstance(v, float):
            return "" if not math.isfinite(v) else f"{v:.{digits}f}"
        if isinstance(v, (list, tuple)):
            return html.escape("; ".join(map(str, v)))
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in (headers or columns))
    body = "\n".join("<tr>" + "".join(f"<td>{fmt(r.get(c))}</td>" for c in columns) + "</tr>"
                     for r in rows)
    return f"<div class='wide'><table>\n<tr>{head}</tr>\n{body}\n</table></div>"


_CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;margin:2em;max-width:1100px;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.6em 0;font-size:.9em}
td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#eef}
td:last-child{text-align:left}.fail{color:#b00}.warn{color:#a60}
.wide{overflow-x:auto;max-width:100%}
.verdict{padding:.6em 1em;margin:.8em 0;border-radius:4px;font-size:1.05em;border:1px solid}
.verdict.pass{background:#e8f6e8;border-color:#7b7;color:#164}
.verdict.fail{background:#fbeaea;border-color:#d77;color:#900}
.verdict.undecided{background:#fff6e0;border-color:#db5;color:#740}
.verdict.info{background:#eef3fb;border-color:#8ab;color:#234}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}
pre{background:#f6f6f6;padding:.6em;font-size:.8em;overflow-x:auto}
"""


def html_page(title: str, sections: Sequence[tuple[str, str]],
              images: Mapping[str, bytes] | None = None) -> str:
    """A complete HTML document; ``{img:NAME}`` in a section becomes an embedded PNG.

    Parameters
    ----------
    title : str
    sections : sequence of (heading, html)
    images : mapping of name -> PNG bytes

    Returns
    -------
    str
    """
    parts = [f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
             f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>"]
    for heading, body in sections:
        for name, data in (images or {}).items():
            token = "{img:" + name + "}"
            if token in body:
                uri = base64.b64encode(data).decode("ascii")
                body = body.replace(token, f"<img alt='{html.escape(name)}' "
                                           f"src='data:image/png;base64,{uri}'>")
        parts.append(f"<h2>{html.escape(heading)}</h2>\n{body}")
    parts.append("</body></html>")
    return "\n".join(parts)


def json_dumps(obj: Any) -> str:

    from ..outputs import to_jsonable

    return json.dumps(to_jsonable(obj), indent=1)


def verdict_banner(lines: Sequence[tuple[str, str]]) -> str:
    """The verdicts at the top of a report: one coloured line each.

    Parameters
    ----------
    lines : sequence of (text, level)
        ``level`` is ``pass``, ``fail`` or ``undecided``.

    Returns
    -------
    str

    Examples
    --------
    >>> "class='verdict fail'" in verdict_banner([("Jacket 2: frame FAILS", "fail")])
    True
    """
    return "\n".join(f"<div class='verdict {level}'>{html.escape(text)}</div>" for text, level in lines)


def provenance_table(parameters: Mapping[str, Any]) -> str:
    """Where a result comes from: input file, size, sha256, software, date and command line.

    Parameters
    ----------
    parameters : mapping
        A result's ``parameters``.

    Returns
    -------
    str
    """
    import datetime as dt

    inp = parameters.get("input", {})
    rows = [{"item": "input file", "value": inp.get("file") or inp.get("source") or "(arrays)"},
            {"item": "size (bytes)", "value": f"{inp['size']:,}" if "size" in inp else ""},
            {"item": "sha256", "value": inp.get("sha256", "")},
            {"item": "soundings used", "value": f"{inp.get('n_points', 0):,}"},
            {"item": "software", "value": parameters.get("software", "")},
            {"item": "report written", "value": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")},
            {"item": "command line",
             "value": " ".join(parameters.get("command_line", [])) or "(library call)"}]
    for key in ("design", "reference"):
        v = parameters.get(key)
        if isinstance(v, dict):
            rows.append({"item": f"{key} file", "value": f"{v.get('file')} ({v.get('size'):,} bytes, sha256 "
                                                            f"{v.get('sha256')})"})
        elif isinstance(v, str):
            rows.append({"item": key, "value": v})
    return html_table(rows, ["item", "value"])


def parameter_table(parameters: Mapping[str, Any]) -> str:
    """The options a result was made with, one row each, readable (not raw JSON).

    Parameters
    ----------
    parameters : mapping
        A result's ``parameters``.

    Returns
    -------
    str
    """
    skip = {"input", "command_line", "software", "design", "reference"}
    rows = []
    for k, v in parameters.items():
        if k in skip:
            continue
        if isinstance(v, (list, dict)):
            v = json.dumps(to_jsonable(v))[:200]
        rows.append({"option": k, "value": "none" if v is None else v})
    return html_table(rows, ["option", "value"], digits=4)
