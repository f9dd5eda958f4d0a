"""Griffe extension: make griffe's static view of ``dynamics`` the one Python has at run time.

* ``dynamics.robots`` is the repository's ``robots/`` directory, installed under that name (pyproject's
  ``package-dir``), so the static loader cannot find it below ``dynamics/``: it is loaded and attached.
* A package that imports a function from a submodule of the same name (``from .reorder import reorder``) has,
  at run time, the function under that name; griffe keeps the submodule there. The member becomes an alias of
  the function again, so that ``dynamics.reorder`` documents the function.
"""

from __future__ import annotations

from typing import Any

import griffe


def _functions_over_modules(mod: griffe.Module) -> None:
    for name, member in list(mod.members.items()):
        if member.is_alias or not isinstance(member, griffe.Module):
            continue
        _functions_over_modules(member)
        if mod.imports.get(name) == f"{member.path}.{name}" and name in member.members:
            mod.set_member(name, griffe.Alias(name, member.members[name], parent=mod))


PAGES = {"dynamics": ("", "torques", "plot", "robots"), "service": ("client",)}


class RuntimeView(griffe.Extension):
    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        if pkg.path == "dynamics":
            _functions_over_modules(pkg)
            if not isinstance(pkg.members.get("robots"), griffe.Module):
                pkg.set_member("robots", loader.load("robots"))
        for name in PAGES.get(pkg.path, ()):
            module = pkg.members.get(name) if name else pkg
            if isinstance(module, griffe.Module):
                module.docstring = None
