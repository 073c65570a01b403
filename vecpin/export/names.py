"""The built-in controller names (``controller``), in a module that imports nothing: the command line
offers them without loading the formats (tests/test_controllers.py keeps them equal to
:data:`vecpin.export.registry.FORMATS`' built-ins)."""

CONTROLLERS = ("siemens-840d", "siemens-828d", "fanuc-30i", "linuxcnc", "beckhoff", "heidenhain", "iso230", "generic")
