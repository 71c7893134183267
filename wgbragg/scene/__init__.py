"""Scenes: the scene model (:mod:`~wgbragg.scene.model`, where every scene class lives) and its
TOML reader (:mod:`~wgbragg.scene.reader`), glTF 2.0 in and out (:mod:`~wgbragg.scene.gltf`,
:mod:`~wgbragg.scene.gltf_export`), MaterialX out (:mod:`~wgbragg.scene.materialx`), meshes,
spatially varying parameter maps and the shipped presets (``presets/*.toml``). The package
exports what a user of scene files needs."""

from wgbragg.scene.gltf import GltfWarning, load_gltf
from wgbragg.scene.gltf_export import save_gltf, scene_to_gltf
from wgbragg.scene.materialx import save_materialx, scene_to_materialx
from wgbragg.scene.model import MODES, PRESETS, Camera, Environment, Scene
from wgbragg.scene.reader import load_preset, load_scene, parse_scene

__all__ = ["MODES", "PRESETS", "Camera", "Environment", "GltfWarning", "Scene", "load_gltf",
           "load_preset", "load_scene", "parse_scene", "save_gltf", "save_materialx",
           "scene_to_gltf", "scene_to_materialx"]
