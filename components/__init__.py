"""pkmstiff component model library: drives, guides, struts, joints, bearings and bodies (docs/theory/components.md).

All quantities are SI; every component evaluates a batch of N poses at once from a
:class:`~components.protocol.ComponentState`. Each model module declares its machine-file models once, next to
the classes (``MODELS``: :class:`~components.params.ModelSpec` with :class:`~components.params.Param` entries);
:func:`components.registry.build_component` reads ``[components.<name>]`` tables by those declarations, and
:mod:`components.catalogue` generates the ``pkmstiff components`` listing and the catalogue page from them.
The library depends on the core only through :mod:`pkmstiff.units` and :mod:`pkmstiff.errors`.
"""

from components.protocol import Component, ComponentRangeError, ComponentState, ConstantAxial, parallel, series

__all__ = ["Component", "ComponentRangeError", "ComponentState", "ConstantAxial", "parallel", "series"]
