"""Scenes: the scene model and its TOML reader, meshes, spatially varying parameter maps and the
shipped presets (``presets/*.toml``)."""
