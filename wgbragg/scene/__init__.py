"""Scenes: the scene model (:mod:`~wgbragg.scene.model`, where every scene class lives) and its
TOML reader (:mod:`~wgbragg.scene.reader`), meshes, spatially varying parameter maps and the
shipped presets (``presets/*.toml``). The package exports what a user of scene files needs."""

from wgbragg.scene.model import MODES, PRESETS, Camera, Environment, Scene
from wgbragg.scene.reader import load_preset, load_scene, parse_scene

__all__ = ["MODES", "PRESETS", "Camera", "Environment", "Scene", "load_preset", "load_scene",
           "parse_scene"]
