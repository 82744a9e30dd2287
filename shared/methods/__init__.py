"""The embedded methods presets (TOML): prefab, conventional, lifted; common.toml (shared/methods_file.py)."""
