"""pkmstiff component model library: drives, guides, struts, joints, bearings and bodies (docs/theory/components.md).

All quantities are SI; every component evaluates a batch of N poses at once from a
:class:`~components.protocol.ComponentState`. Build components from machine-file tables with
:func:`components.registry.build_component`.
"""

from components.protocol import Component, ComponentRangeError, ComponentState, ConstantAxial, parallel, series

__all__ = ["Component", "ComponentRangeError", "ComponentState", "ConstantAxial", "parallel", "series"]
