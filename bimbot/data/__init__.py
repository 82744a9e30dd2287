"""The bundled model, written by ``bimbot sample light-steel-frame`` (a package: it installs as data)."""
