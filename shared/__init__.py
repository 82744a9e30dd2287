"""The project's own shared code: message models, key expressions, bus setup, identifiers, manifest."""
