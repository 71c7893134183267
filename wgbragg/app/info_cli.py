"""``wgbragg info``: the adapter, its driver and where it came from, and ``--fetch-driver``.

Like the other commands, it imports what it runs when it runs, so ``wgbragg --help`` stays
fast.
"""

from __future__ import annotations

import sys

__all__ = ["add_info_command", "run_info"]


def run_info(args) -> int:
    """``wgbragg info``: the adapter with its driver, the loop budget and the folders."""
    import wgpu

    from wgbragg import gpu
    from wgbragg._version import __version__
    from wgbragg.gpu.driver import driver_cache_dir, system_lavapipe
    from wgbragg.gpu.driver_fetch import fetch_driver

    fetched = None
    if args.fetch_driver:
        fetched = fetch_driver(force=args.force)
        print(fetched.message, file=sys.stderr)
    print(f"wgbragg {__version__}, wgpu {wgpu.__version__}")
    info = gpu.adapter_info()
    for key, value in info.items():
        print(f"  {key}: {value}")
    budget = gpu.loop_budget()
    print(f"  loop budget: {'none (loops run to the end)' if budget is None else budget}")
    system = system_lavapipe()
    if system is not None:
        version = ".".join(map(str, system[1])) if system[1] else "of unknown version"
        print(f"  system lavapipe: Mesa {version} ({system[0]})")
    print(f"  driver cache: {driver_cache_dir()}")
    print(f"  shaders: {gpu.shader_dir()}")
    return 0 if fetched is None or fetched.ok else 1


def add_info_command(commands, command) -> None:
    """Add ``info`` to the CLI's sub-commands; ``command`` is the CLI's parser maker."""
    info = command(commands, "info", "adapter, driver (Mesa version and where it came from), "
                                      "versions and shader folder")
    info.add_argument("--fetch-driver", action="store_true",
                      help="first fetch a current lavapipe (Mesa >= 24) from the distribution's "
                           "backports suite into wgbragg's driver cache, when the system's is "
                           "older; installs no system package (exit status 1 if none could be "
                           "had: wgbragg then goes on with the system driver)")
    info.add_argument("--force", action="store_true",
                      help="with --fetch-driver: fetch again even if a current driver is there")
    info.set_defaults(run=run_info)
