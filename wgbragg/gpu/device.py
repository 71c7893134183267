"""The process-wide wgpu device: adapter choice and limits.

One device per process (:func:`get_device`), on the adapter that ``WGBRAGG_ADAPTER`` names or
else the one wgpu prefers; :func:`adapter_info` describes it, and :func:`max_buffer_bytes`
bounds every buffer a kernel binds. Where the device ends loops early:
:mod:`wgbragg.gpu.loops`.

Environment
-----------
``WGBRAGG_ADAPTER``
    Case-insensitive substring of the adapter's device name or description
    selecting the adapter, e.g. ``llvmpipe``.
"""

from __future__ import annotations

import functools
import os
import tempfile
from collections.abc import Mapping, Sequence
from typing import Any

import wgpu

from wgbragg.gpu.driver import apply_driver_choice, mesa_version

# mappable-primary-buffers (wgpu-native): on a CPU adapter, whose buffers are host memory,
# streams map their storage buffers directly instead of copying through staging buffers
# (wgbragg.gpu.streams).
_OPTIONAL_FEATURES = ("timestamp-query", "shader-f64", "mappable-primary-buffers")

# Backends in order of preference when several adapters match WGBRAGG_ADAPTER:
# the project targets Vulkan; GL adapters (lavapipe also shows up as one) go last.
_BACKEND_RANK = {"vulkan": 0, "metal": 1, "d3d12": 2}

# Limits requested at the adapter's own values rather than the WebGPU defaults.
_RAISED_LIMITS = ("max-compute-invocations-per-workgroup", "max-compute-workgroup-size-x",
                  "max-storage-buffer-binding-size", "max-buffer-size")

_NO_ADAPTER = "no Vulkan adapter found: install mesa-vulkan-drivers (lavapipe)"


# --------------------------------------------------------------------------- adapter


def select_adapter(infos: Sequence[Mapping[str, Any]], pattern: str) -> int:
    """Index of the adapter whose name matches ``pattern``.

    Parameters
    ----------
    infos : sequence of mapping
        Adapter infos as ``GPUAdapter.info`` gives them (keys ``device``,
        ``description``, ``backend_type``).
    pattern : str
        Case-insensitive substring of ``device`` or ``description``.

    Returns
    -------
    int
        Index into ``infos``; among several matches the Vulkan one is preferred.

    Raises
    ------
    RuntimeError
        If nothing matches; the message lists the available adapters.
    """
    needle = pattern.lower()
    matches = [
        i
        for i, info in enumerate(infos)
        if needle in str(info.get("device", "")).lower()
        or needle in str(info.get("description", "")).lower()
    ]
    if not matches:
        available = "; ".join(
            f"{info.get('device', '?')} [{info.get('backend_type', '?')}]" for info in infos
        )
        raise RuntimeError(
            f"WGBRAGG_ADAPTER={pattern!r} matches no adapter; available: {available or 'none'}"
        )
    return min(
        matches,
        key=lambda i: _BACKEND_RANK.get(str(infos[i].get("backend_type", "")).lower(), 9),
    )


def _find_adapter() -> Any:
    """The adapter ``WGBRAGG_ADAPTER`` names, else the one wgpu prefers, on the driver list
    :func:`~wgbragg.gpu.driver.apply_driver_choice` sets first."""
    apply_driver_choice()
    pattern = os.environ.get("WGBRAGG_ADAPTER", "").strip()
    if pattern:
        adapters = wgpu.gpu.enumerate_adapters_sync()
        if not adapters:
            raise RuntimeError(_NO_ADAPTER)
        return adapters[select_adapter([a.info for a in adapters], pattern)]
    try:
        adapter = wgpu.gpu.request_adapter_sync(power_preference="high-performance")
    except Exception as exc:
        raise RuntimeError(_NO_ADAPTER) from exc
    if adapter is None:
        raise RuntimeError(_NO_ADAPTER)
    return adapter


@functools.cache
def _adapter_and_device() -> tuple[Any, wgpu.GPUDevice]:
    if not os.environ.get("XDG_RUNTIME_DIR"):
        # Mesa's window-system probing prints an error per adapter without it; headless compute
        # needs no real one, so any private folder will do.
        os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="wgbragg-xdg-")
    adapter = _find_adapter()
    features = [f for f in _OPTIONAL_FEATURES if f in adapter.features]
    # The WebGPU default caps workgroups at 256 invocations; software rasterisers such as
    # lavapipe pay a fixed cost per workgroup, so ask for what the adapter really allows.
    # Buffers too: the WebGPU defaults (128 MiB a binding, 256 MiB a buffer) are below what
    # real GPUs hold.
    limits = {name: adapter.limits[name] for name in _RAISED_LIMITS if name in adapter.limits}
    device = adapter.request_device_sync(required_features=features, required_limits=limits)
    return adapter, device


def get_device() -> wgpu.GPUDevice:
    """The process-wide wgpu device, created on first use.

    Returns
    -------
    wgpu.GPUDevice
        With ``timestamp-query`` and ``shader-f64`` enabled where the adapter has them.

    Raises
    ------
    RuntimeError
        If no adapter exists, or ``WGBRAGG_ADAPTER`` matches none.
    """
    return _adapter_and_device()[1]


def adapter_info() -> dict[str, Any]:
    """Name, driver, backend and type of the adapter behind :func:`get_device`.

    Returns
    -------
    dict
        ``name``, ``description`` (the driver's own, e.g. ``"Mesa 25.0.7 (LLVM 15.0.6)"``),
        ``backend``, ``adapter_type``, ``is_lavapipe`` (``"llvmpipe"`` in the name, Mesa's
        CPU Vulkan driver), ``mesa`` (the Mesa version the description names, or ``""``),
        ``driver_source`` (``"user"``, ``"system"``, ``"cache"`` or ``"old"``:
        :mod:`wgbragg.gpu.driver`) and ``driver``, one line naming the adapter with its
        driver version, as every benchmark and render records it.
    """
    info = _adapter_and_device()[0].info
    name = str(info.get("device", ""))
    description = str(info.get("description", ""))
    backend = str(info.get("backend_type", ""))
    version = mesa_version(description)
    mesa = ".".join(map(str, version)) if version else ""
    driver = f"{name}, {'Mesa ' + mesa if mesa else description or 'unknown driver'} [{backend}]"
    return {
        "name": name,
        "description": description,
        "backend": backend,
        "adapter_type": str(info.get("adapter_type", "")),
        "is_lavapipe": "llvmpipe" in name.lower(),
        "mesa": mesa,
        "driver_source": apply_driver_choice().source,
        "driver": driver,
    }


# --------------------------------------------------------------------------- limits


def max_buffer_bytes() -> int:
    """The largest storage buffer a kernel can bind on this device, in bytes.

    It bounds every per-pixel or per-invocation array: 128 MiB on lavapipe (8,388,608 vec4
    pixels), more on most real GPUs. :class:`~wgbragg.gpu.pipelines.DeviceArray` refuses larger
    ones with a ValueError, and the public entry points that size buffers from user input check
    it first, naming their parameter.
    """
    limits = get_device().limits
    return int(min(limits["max-storage-buffer-binding-size"], limits["max-buffer-size"]))


def check_buffer_size(nbytes: int, what: str) -> None:
    """Raise ValueError if a buffer of ``nbytes`` exceeds :func:`max_buffer_bytes`.

    Parameters
    ----------
    nbytes : int
    what : str
        What the buffer holds, for the message.
    """
    largest = max_buffer_bytes()
    if nbytes > largest:
        raise ValueError(
            f"{what}: {nbytes} bytes exceed this GPU's largest storage buffer ({largest} bytes,"
            f" {adapter_info()['name']}); split the work or reduce its size"
        )
