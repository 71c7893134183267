"""Light: equirectangular environment maps, procedural environments, prefiltered environments
and the image-based-lighting reflectance terms."""
