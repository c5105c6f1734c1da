"""The Jinja2 environment of the apps' HTML reports (export's report.html, the review's report).

Templates are package data: ``templates/NAME.html.j2`` inside the package that renders them.
Every value a template prints is escaped (autoescape), with :func:`html.escape`'s rules (quotes
included: a shot name or a note may go into an attribute); a value already marked safe
(:class:`markupsafe.Markup`, the data URL of an inline image) is printed as it is.
"""

from __future__ import annotations

import functools
import html

from jinja2 import Environment, PackageLoader, StrictUndefined
from markupsafe import Markup


def _escaped(value) -> Markup:
    # html.escape, not markupsafe's own: the reports have always written ' as &#x27;
    return value if isinstance(value, Markup) else Markup(html.escape(str(value)))


@functools.cache
def _environment(package: str) -> Environment:
    return Environment(
        loader=PackageLoader(package, "templates"),
        autoescape=True,
        finalize=_escaped,
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def render(package: str, name: str, **values) -> str:
    """The template ``name`` of ``package`` (e.g. ``mrcheck.apps.export``, ``report.html.j2``)."""
    return _environment(package).get_template(name).render(**values)


__all__ = ["render"]
