"""Reflection models built on the optics: GGX microfacets, the transmission filter and rough
Bragg layers, rough thin films, layered Bragg structures, and the material classes
(:class:`BraggMirror`, :class:`ThinFilm`) the public API hands out."""
