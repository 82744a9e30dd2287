"""The default fleet (default_fleet.toml) and bimbot's own robot models (URDF): package data only."""
