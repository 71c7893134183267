"""GPU harness: the wgpu device, WGSL sources, cached compute pipelines and their dispatch.

Every kernel of the package runs through it: one device per process, WGSL composed from the
``wgsl/`` folder, pipelines cached by source, entry point and override constants, and kernels
that upload numpy arrays, dispatch and read back. The names below are its public API; each
lives in the submodule for its job, whose docstring says more:

- :mod:`~wgbragg.gpu.device`: adapter (``WGBRAGG_ADAPTER``), device, buffer limits and
  llvmpipe's "Loop budget";
- :mod:`~wgbragg.gpu.shaders`: shader folder, include composer, compile errors;
- :mod:`~wgbragg.gpu.specialise`: the ``//! if`` blocks that override constants resolve;
- :mod:`~wgbragg.gpu.layouts`: WGSL uniform structs and bilinear cell quads;
- :mod:`~wgbragg.gpu.timing`: GPU timestamps and :func:`pass_clock`;
- :mod:`~wgbragg.gpu.pipelines`: the "Binding convention", "Dispatch", "Any element count"
  (:class:`Rows`), "Chained dispatches" and "Specialisation" of kernels, device arrays,
  :func:`submit` and :func:`benchmark`.
"""

from wgbragg.gpu.device import (
    LOOP_BUDGET,
    SAFE_LOOP_ITERATIONS,
    LoopBudgetError,
    adapter_info,
    check_loops,
    get_device,
    max_buffer_bytes,
    select_adapter,
)
from wgbragg.gpu.layouts import (
    BILINEAR_QUADS_MAX_BYTES,
    bilinear_quads,
    bilinear_quads_fit,
    struct_dtype,
)
from wgbragg.gpu.pipelines import (
    DeviceArray,
    Dispatch,
    Kernel,
    Rows,
    benchmark,
    compute_pipeline,
    pipeline_cache_info,
    submit,
)
from wgbragg.gpu.shaders import ShaderCompileError, ShaderSource, load_shader, shader_dir
from wgbragg.gpu.timing import PassClock, pass_clock

__all__ = [
    "BILINEAR_QUADS_MAX_BYTES",
    "LOOP_BUDGET",
    "SAFE_LOOP_ITERATIONS",
    "DeviceArray",
    "Dispatch",
    "Kernel",
    "LoopBudgetError",
    "PassClock",
    "Rows",
    "ShaderCompileError",
    "ShaderSource",
    "adapter_info",
    "benchmark",
    "bilinear_quads",
    "bilinear_quads_fit",
    "check_loops",
    "compute_pipeline",
    "get_device",
    "load_shader",
    "max_buffer_bytes",
    "pass_clock",
    "pipeline_cache_info",
    "select_adapter",
    "shader_dir",
    "struct_dtype",
    "submit",
]
