"""Low-level helpers every layer may use: validation, atomic file writes, OpenEXR, the LUT
store, quasi-random sampling and image metrics. Imports nothing else from wgbragg."""
