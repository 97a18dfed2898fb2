"""Griffe extension of the documentation build: the docstrings' Sphinx roles become links.

nlobs's docstrings are numpydoc and cross-reference with Sphinx roles (``:func:`simulate```,
``:class:`~nlobs.methods.base.Design```). mkdocstrings renders Markdown, where a role would show as literal text,
so before rendering each role is resolved in the scope of the object whose docstring holds it (its module's
imports and members, then the package) and written as an *optional* autorefs reference: a link where the target is
documented on some page of the site, its name in code font where it is not (a private helper, a NumPy function).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const|term|ref):`(?P<body>[^`]+)`")
TITLED = re.compile(r"^(?P<title>.+?)\s*<(?P<target>[^>]+)>$")


def _candidates(obj: griffe.Object, target: str) -> list[str]:
    """Full paths the target may name, most specific first."""
    target = target.lstrip(".")
    out = [target] if target.startswith("nlobs") else []
    head, _, rest = target.partition(".")
    scope: Any = obj
    while scope is not None:
        try:
            resolved = scope.resolve(head)
        except Exception:  # noqa: BLE001 - griffe raises NameResolutionError and others for unknown names
            resolved = None
        if resolved:
            out.append(resolved + (f".{rest}" if rest else ""))
            break
        scope = scope.parent
    module = obj.module.path if not obj.is_module else obj.path
    package = module.rpartition(".")[0]
    out += [f"{module}.{target}", f"{package}.{target}", f"nlobs.{target}"]
    return list(dict.fromkeys(out))


def _exists(obj: griffe.Object, path: str) -> bool:
    try:
        obj.modules_collection[path]
    except Exception:  # noqa: BLE001 - KeyError, or an alias that cannot be resolved
        return False
    return True


def _target_path(obj: griffe.Object, path: str) -> str:
    """Where the object is defined (an alias, e.g. a re-export in a package's ``__init__``, followed)."""
    try:
        found = obj.modules_collection[path]
        return found.final_target.path if found.is_alias else found.path
    except Exception:  # noqa: BLE001
        return path


def _link(obj: griffe.Object, body: str) -> str:
    m = TITLED.match(body)
    title, target = (m["title"], m["target"]) if m else (None, body)
    short = target.startswith("~")
    target = target.lstrip("~")
    shown = title or (target.rsplit(".", 1)[-1] if short else target)
    found = next((c for c in _candidates(obj, target) if c.startswith("nlobs") and _exists(obj, c)), None)
    if found is None:
        return f"`{shown}`"
    return f'<autoref identifier="{_target_path(obj, found)}" optional><code>{shown}</code></autoref>'


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring of the loaded package as optional autorefs links."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:  # noqa: ARG002 - griffe's hook signature
        seen: set[int] = set()

        def visit(obj: griffe.Object) -> None:
            if id(obj) in seen:
                return
            seen.add(id(obj))
            if obj.docstring is not None and ":" in obj.docstring.value:
                obj.docstring.value = ROLE.sub(lambda m: _link(obj, m["body"]), obj.docstring.value)
            for member in obj.members.values():
                if not member.is_alias:
                    visit(member)

        visit(pkg)
