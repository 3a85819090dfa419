# SPDX-License-Identifier: GPL-3.0-or-later
"""The method registry: every synthesis method the panel, the operators and the command line offer, in menu
order. Adding a method = a family package with a method.py declaring its MethodFamily
(core/method_spec.py), and one import line below. bpy-free and numpy-free (the CLI builds its parser from it)."""
from .core import settings as _settings
from .core.method_spec import MethodFamily

# The registry: one line per family, in menu order (every MethodFamily imported here is registered below).
from .uv_methods.method import FAMILY as uv_methods
from .surface_colour.method import FAMILY as surface_colour
from .particles.method import FAMILY as particles

FAMILIES = []


def register(family):
    """Adds a family's methods (also at run time, e.g. a test's); its ids become valid Settings.method values."""
    if family not in FAMILIES:
        FAMILIES.append(family)
    for spec in family.methods:
        _settings.register_method(spec)


def unregister(family):
    if family in FAMILIES:
        FAMILIES.remove(family)
    for spec in family.methods:
        _settings.unregister_method(spec.id)


def all_methods():
    return [spec for family in FAMILIES for spec in family.methods]


def get(method_id):
    """The MethodSpec of a Settings.method / panel enum id; KeyError for an unknown one."""
    for spec in all_methods():
        if spec.id == method_id:
            return spec
    raise KeyError(method_id)


def by_cli_name(name):
    for spec in all_methods():
        if spec.cli_name == name:
            return spec
    raise KeyError(name)


def family_of(spec):
    return next(family for family in FAMILIES if spec in family.methods)


def enum_items():
    """The panel's Method menu: (id, label, description) per method."""
    return tuple((spec.id, spec.label, spec.description) for spec in all_methods())


for _family in [value for value in list(globals().values()) if isinstance(value, MethodFamily)]:
    register(_family)
