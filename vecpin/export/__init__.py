"""Controller files: one module per format, each with its writer, reader and limits.

:mod:`~vecpin.export.registry` maps controller names (``controller``) to formats; a machine's
controller facts (NC axis names, reference positions, modulo axes, detection units,
limits) come from a :class:`~vecpin.export.profile.ControllerProfile`. The export
layer may import the compensation layer (tables, limits), never the reverse.
"""
