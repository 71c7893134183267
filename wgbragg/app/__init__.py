"""What users run: the ``wgbragg`` command line, the demo viewer and its window, scatterogram and
reflectance-map figures."""
