"""MaterialX out: a scene's materials as OpenPBR surfaces (``open_pbr_surface``, MaterialX 1.39).

- A thin film is ``thin_film_weight = 1``, ``thin_film_thickness`` in micrometres (OpenPBR's
  unit: ``thickness_nm / 1000``) and ``thin_film_ior = n_film`` over its base: a dielectric
  specular layer of ``specular_ior = n_base`` with no diffuse (``base_weight = 0``), or a metal
  (``base_metalness = 1``) of the base's normal-incidence colour. A thickness map is an
  ``image`` node of the map's texture (a procedural map baked into a PNG beside the document),
  scaled to the map's range.
- A Lambertian material is the diffuse base alone (``specular_weight = 0``).
- A layered Bragg material has no OpenPBR counterpart: it is written as the same fallback as in
  glTF (a metal of the fitted base colour under the fitted film,
  :func:`wgbragg.scene.gltf_fallback.fit_fallback`), with its exact parameters as JSON in the
  shader's ``doc`` string.

GGX roughness: OpenPBR's ``specular_roughness`` r gives ``alpha = r**2``, so ``r = sqrt(alpha)``.
Documents are checked by MaterialX's own validation (:func:`validate_materialx`) before they are
written. :mod:`MaterialX` (pip package ``materialx``) is imported on first use.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from wgbragg.common.atomic import atomic_path
from wgbragg.scene.gltf_export import map_image, map_png, material_base_colour
from wgbragg.scene.gltf_fallback import fit_fallback
from wgbragg.scene.model import (
    LambertianMaterial,
    LayeredBraggMaterial,
    Scene,
    ThinFilmMaterial,
)

__all__ = ["save_materialx", "scene_to_materialx", "validate_materialx"]


def _valid_name(mx, name: str, taken: set) -> str:
    base = mx.createValidName(name) or "material"
    candidate, k = base, 2
    while candidate in taken:
        candidate, k = f"{base}_{k}", k + 1
    taken.add(candidate)
    return candidate


def _set(shader, name: str, kind: str, value) -> None:
    """An input of ``shader`` with every digit of ``value`` (MaterialX writes 6 by default)."""
    values = value if isinstance(value, tuple | list) else (value,)
    shader.addInput(name, kind).setValueString(", ".join(repr(float(v)) for v in values))


def scene_to_materialx(scene: Scene, folder: str | os.PathLike | None = None,
                       stem: str = "materials") -> tuple[str, dict[str, bytes]]:
    """The scene's materials as a MaterialX document.

    Parameters
    ----------
    scene : Scene
    folder : str or os.PathLike, optional
        Where the document will lie: map textures are named relative to it.
    stem : str
        Prefix of the baked map textures' file names.

    Returns
    -------
    text : str
        The document (XML), validated.
    textures : dict of str to bytes
        PNG files the document names, by file name (relative to ``folder``).

    Raises
    ------
    ValueError
        If MaterialX's validation refuses the document (a bug: the message says why).
    """
    import MaterialX as mx  # noqa: N813 (MaterialX's own spelling); heavy: only when a document is made

    doc = mx.createDocument()
    textures: dict[str, bytes] = {}
    taken: set = set()
    for name, material in scene.materials.items():
        shader_name = _valid_name(mx, f"{name}_surface", taken)
        shader = doc.addNode("open_pbr_surface", shader_name, "surfaceshader")
        if isinstance(material, LambertianMaterial):
            albedo = material.albedo
            colour = (albedo,) * 3 if isinstance(albedo, float | int) else tuple(albedo)
            _set(shader, "base_weight", "float", 1.0)
            _set(shader, "base_color", "color3", colour)
            _set(shader, "specular_weight", "float", 0.0)
        elif isinstance(material, ThinFilmMaterial):
            _set(shader, "specular_roughness", "float", math.sqrt(material.alpha))
            if material.base is None and material.k_base == 0.0:
                _set(shader, "base_weight", "float", 0.0)
                _set(shader, "specular_ior", "float", float(material.n_base))
            else:
                _set(shader, "base_metalness", "float", 1.0)
                _set(shader, "base_color", "color3", material_base_colour(material))
            _set(shader, "thin_film_weight", "float", 1.0)
            _set(shader, "thin_film_ior", "float", float(material.n_film))
            pmap = material.thickness_map
            if pmap is None:
                _set(shader, "thin_film_thickness", "float", material.thickness_nm / 1000.0)
            else:
                file = f"{stem}_{_valid_name(mx, name, set())}_thickness.png"
                textures[file] = map_png(map_image(pmap))
                image = doc.addNode("image", _valid_name(mx, f"{name}_thickness_map", taken),
                                    "float")
                image.setInputValue("file", file, "filename")
                low, high = (v / 1000.0 for v in pmap.range)
                scaled = doc.addNode("multiply", _valid_name(mx, f"{name}_thickness_scale",
                                                             taken), "float")
                scaled.setConnectedNode("in1", image)
                _set(scaled, "in2", "float", high - low)
                offset = doc.addNode("add", _valid_name(mx, f"{name}_thickness_um", taken),
                                     "float")
                offset.setConnectedNode("in1", scaled)
                _set(offset, "in2", "float", low)
                shader.addInput("thin_film_thickness", "float").setConnectedNode(offset)
        elif isinstance(material, LayeredBraggMaterial):
            fallback = fit_fallback(material)
            layers = [{"n1": s.n1, "n2": s.n2, "d1_nm": s.d1_nm, "d2_nm": s.d2_nm, "N": s.N,
                       "alpha": s.alpha, **({"host": s.host} if s.host is not None else {})}
                      for s in material.layers]
            shader.setDocString(
                "wgbragg layered-bragg (no OpenPBR counterpart; shown as a fitted thin film "
                f"over a metal, mean dE2000 {fallback.delta_e_mean:.1f} over 0-80 degrees): "
                + json.dumps({"layers": layers, "base_albedo": material.base_albedo}))
            _set(shader, "base_metalness", "float", 1.0)
            _set(shader, "base_color", "color3", fallback.base_colour)
            _set(shader, "specular_roughness", "float", math.sqrt(material.layers[0].alpha))
            _set(shader, "thin_film_weight", "float", 1.0)
            _set(shader, "thin_film_thickness", "float", fallback.thickness_nm / 1000.0)
            _set(shader, "thin_film_ior", "float", fallback.ior)
        else:
            raise ValueError(f"material {name!r}: cannot be exported ({type(material).__name__})")
        surface = doc.addMaterialNode(_valid_name(mx, name, taken), shader)
        del surface
    text = mx.writeToXmlString(doc)
    ok, message = validate_materialx(text)
    if not ok:
        raise ValueError(f"the MaterialX document is invalid: {' '.join(message.split())}")
    return text, textures


def validate_materialx(text: str) -> tuple[bool, str]:
    """MaterialX's own validation of a document, against its standard libraries.

    Returns
    -------
    (bool, str)
        Whether it is valid, and MaterialX's message.
    """
    import MaterialX as mx  # noqa: N813

    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    library = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), library)
    doc.setDataLibrary(library) if hasattr(doc, "setDataLibrary") else doc.importLibrary(library)
    return doc.validate()


def save_materialx(scene: Scene, path: str | os.PathLike) -> Path:
    """Write the scene's materials to a ``.mtlx`` file (and its map textures beside it),
    atomically.

    Raises
    ------
    ValueError
        If the path does not end in ``.mtlx``.
    OSError
        When a file cannot be written (naming it).
    """
    path = Path(path)
    if path.suffix.lower() != ".mtlx":
        raise ValueError(f"{path}: a MaterialX file must end in .mtlx")
    text, textures = scene_to_materialx(scene, path.parent, stem=path.stem)
    for name, data in textures.items():
        with atomic_path(path.parent / name) as temporary:
            temporary.write_bytes(data)
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return path
