"""GPU harness: the wgpu device, WGSL sources, cached compute pipelines and their dispatch.

Every kernel of the package runs through it: one device per process, WGSL composed from the
``wgsl/`` folder, pipelines cached by source, entry point and override constants, and kernels
that upload numpy arrays, dispatch and read back. The names below are its public API; each
lives in the submodule for its job, whose docstring says more:

- :mod:`~wgbragg.gpu.driver`: the Vulkan driver list chosen before the first adapter (the
  user's, the system's, or a current lavapipe from the driver cache), and
  :mod:`~wgbragg.gpu.driver_fetch`, which fills that cache from the backports suite;
- :mod:`~wgbragg.gpu.device`: adapter (``WGBRAGG_ADAPTER``), device and buffer limits;
- :mod:`~wgbragg.gpu.shaders`: shader folder, include composer, compile errors;
- :mod:`~wgbragg.gpu.specialise`: the ``//! if`` blocks that override constants resolve;
- :mod:`~wgbragg.gpu.layouts`: WGSL uniform structs and bilinear cell quads;
- :mod:`~wgbragg.gpu.timing`: GPU timestamps and :func:`pass_clock`;
- :mod:`~wgbragg.gpu.pipelines`: the "Binding convention", "Dispatch", "Any element count"
  (:class:`Rows`), "Chained dispatches" and "Specialisation" of kernels, device arrays,
  :func:`submit` and :func:`benchmark`, with :mod:`~wgbragg.gpu.arrays` (device arrays,
  dispatches, submission) and :mod:`~wgbragg.gpu.buffers` (the pool of reused buffers);
- :mod:`~wgbragg.gpu.streams`: block-wise streams of points through kept buffers, for the
  public array calls;
- :mod:`~wgbragg.gpu.loops`: the device's "Loop budget", measured by a probe kernel, and the
  iterations kernels plan for;
- :mod:`~wgbragg.gpu.bindings`: the bindings a source declares and their layout entries;
  :mod:`~wgbragg.gpu.rows`: per-invocation inputs made a block at a time (:class:`Rows`);
- :mod:`~wgbragg.gpu.render_pipelines`: render pipelines (vertex + fragment), cached like
  compute pipelines, for the rasterizer.
"""

from wgbragg.gpu.device import (
    adapter_info,
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
from wgbragg.gpu.loops import (
    ITERATIONS_WITHOUT_BUDGET,
    LoopBudgetError,
    check_loops,
    describe_loop_budget,
    loop_budget,
    planned_loop_iterations,
    safe_loop_iterations,
)
from wgbragg.gpu.pipelines import (
    DeviceArray,
    Dispatch,
    Kernel,
    benchmark,
    compute_pipeline,
    pipeline_cache_info,
    submit,
)
from wgbragg.gpu.rows import Rows
from wgbragg.gpu.shaders import ShaderCompileError, ShaderSource, load_shader, shader_dir
from wgbragg.gpu.timing import PassClock, pass_clock

__all__ = [
    "BILINEAR_QUADS_MAX_BYTES",
    "ITERATIONS_WITHOUT_BUDGET",
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
    "describe_loop_budget",
    "get_device",
    "load_shader",
    "loop_budget",
    "max_buffer_bytes",
    "pass_clock",
    "pipeline_cache_info",
    "planned_loop_iterations",
    "safe_loop_iterations",
    "select_adapter",
    "shader_dir",
    "struct_dtype",
    "submit",
]
