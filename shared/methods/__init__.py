"""The embedded methods presets (TOML): prefab, conventional, and common.toml (see shared/methods_file.py)."""
