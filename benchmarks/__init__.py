"""wgbragg's benchmarks: speed and accuracy of its methods, side by side with its references
and peers, on the machine at hand.

One module per benchmark, each run from the repository root::

    python -m benchmarks.reflectance   # reflectance throughput: GPU kernel, numpy, tmm, tmm_fast
    python -m benchmarks.rgb           # colour methods of BraggMirror.xyz: time and dE2000
    python -m benchmarks.film          # thin-film colour methods
    python -m benchmarks.rough         # rough Bragg layers: filter bake, transmissivity tables
    python -m benchmarks.layered       # layered model against Monte Carlo simulation
    python -m benchmarks.render        # the renderer's throughput
    python -m benchmarks.ibl           # filtered image-based lighting
    python -m benchmarks.viewer        # the viewer's interactive budgets
    python -m benchmarks.memory        # peak RSS of large reflectance calls (bounded work)

``make bench`` runs them all. A full run rewrites the benchmark's own section of
``docs/benchmarks.md`` (between its markers; the rest of the file is left alone); ``--quick``
runs tiny sizes in seconds and writes nothing unless ``--output FILE`` is given (the tests
run every benchmark so); ``--no-write`` prints the section only and ``--no-progress`` hides the
progress bars. ``python -m benchmarks.NAME --help`` lists a benchmark's own options.

The code every benchmark shares (the document's sections, the facts of a run, tables and number
formats, the command line) is :mod:`benchmarks.report`. The package is part of the source
distribution, not of the wheel.
"""
