"""Colour of a structure: colorimetry, the spectral reference, the landmark methods, the grid
quadrature, thin-film Fourier colour and the ``method=`` registry on top. Each numpy twin sits
beside the module that dispatches its WGSL kernel (``wgsl/colour/``)."""
