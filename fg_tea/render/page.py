"""How every page fg_tea writes receives its data (docs/design.md §9.2).

A page is a template filled **once**: :func:`fill` finds every slot of the template in one scan
and puts each value in its place, so text already inserted is never searched again (a name that
contains a slot's marker stays that name). Each value is escaped for the context of its slot
before it is handed to :func:`fill`:

- :func:`html_text` for HTML text and double-quoted attribute values (``&``, ``<``, ``>``, ``"``
  and ``'`` become entities);
- :func:`json_script` for the content of a ``<script type="application/json">`` block, which the
  page reads with ``JSON.parse``: ``<``, ``>`` and ``&`` are written as ``\\u003c``, ``\\u003e``,
  ``\\u0026``, so no ``</script>``, ``<!--`` or marker can appear in the block;
- :func:`content_security_policy` for the page's Content-Security-Policy ``<meta>``: script runs
  only if it is the page's own (by its SHA-256 hash), so an inline event handler or an injected
  ``<script>`` does not run even if markup ever reached the page; nothing is fetched from a
  network.

Lone surrogates (a name read from a JSON ``\\ud800`` escape) cannot be written as UTF-8: in HTML
text they become U+FFFD; in JSON they stay ``\\ud800`` escapes, which ``JSON.parse`` reads back.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import re
from typing import Any, Mapping

#: A slot in a template: ``{{NAME}}`` (text and attributes) or ``/*NAME*/`` (inside a block).
SLOT = re.compile(r"\{\{([A-Z_]+)\}\}|/\*([A-Z_]+)\*/")
_SURROGATE = re.compile("[\ud800-\udfff]")


def fill(template: str, slots: Mapping[str, str]) -> str:
    """`template` with every slot replaced by its value, in one scan of the template.

    Raises:
        KeyError: the template has a slot that `slots` does not fill, or `slots` fills one the
            template does not have (a programming error, not bad input).
    """
    used: set[str] = set()

    def value(match: re.Match) -> str:
        name = match.group(1) or match.group(2)
        used.add(name)
        return slots[name]

    page = SLOT.sub(value, template)
    if set(slots) - used:
        raise KeyError(f"the template has no slot for {sorted(set(slots) - used)}")
    return page


def html_text(text: Any) -> str:
    """`text` escaped for HTML text or a quoted attribute value."""
    return html.escape(_SURROGATE.sub("\ufffd", str(text)), quote=True)


def json_script(value: Any) -> str:
    """`value` as JSON safe inside ``<script type="application/json">`` (ASCII only, no ``<``,
    ``>`` or ``&``); non-finite floats are refused (``allow_nan=False``)."""
    text = json.dumps(value, separators=(",", ":"), allow_nan=False, ensure_ascii=True)
    return text.replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")


def script_hash(script: str) -> str:
    """The CSP source expression that allows exactly this inline script."""
    digest = hashlib.sha256(script.encode("utf-8")).digest()
    return "'sha256-" + base64.b64encode(digest).decode("ascii") + "'"


def content_security_policy(*scripts: str, media: bool = False) -> str:
    """The policy of a page whose only script is `scripts` (inlined): no other script, no inline
    event handler, no network; styles inline; images as data URLs; with `media`, a video file
    beside the page (``file:`` or the page's own origin)."""
    script_src = " ".join(script_hash(s) for s in scripts) or "'none'"
    parts = ["default-src 'none'", f"script-src {script_src}", "style-src 'unsafe-inline'",
             "img-src data:", "base-uri 'none'", "form-action 'none'"]
    if media:
        parts.append("media-src 'self' file:")
    return "; ".join(parts)
