"""The bundled model and what makes it: ``light_steel_frame.ifc``, written by ``bimbot sample
light-steel-frame`` (:mod:`.sample_cli`) from the pure generator :mod:`.light_steel_frame` (a package: the
model installs as data beside the code that made it)."""
