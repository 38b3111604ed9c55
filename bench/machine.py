"""What every benchmark records about the machine it ran on.

Timings and their ratios depend on the CPU, not only on the code: the same build gave `st`
×5.8 over `pt` on the dielectric bunny at σt = 1000 on an AMD EPYC (Zen 4) and ×4.75 on an
Intel Xeon (Cascade Lake), where a sphere step's decoders cost 2.8 times as much
(bench/README.md, "Which CPU"). Python's `platform.processor()` is empty on Linux, so the
CPU's model name is read from /proc/cpuinfo.

    python -m bench.machine      # prints the record as JSON
"""

from __future__ import annotations

import argparse
import json
import os
import platform
from pathlib import Path


def _cpuinfo() -> dict[str, str]:
    """The first processor's fields in /proc/cpuinfo (empty where there is none)."""
    fields: dict[str, str] = {}
    path = Path("/proc/cpuinfo")
    if path.is_file():
        for line in path.read_text(errors="replace").splitlines():
            if not line.strip():
                break
            key, _, value = line.partition(":")
            fields[key.strip()] = value.strip()
    return fields


def cpu_model() -> str:
    """The CPU's model name and, on x86, its family, model and stepping (a virtual machine's
    model name often hides the generation: "Intel Xeon Processor" is Cascade Lake at family
    6, model 85, stepping 7)."""
    info = _cpuinfo()
    name = info.get("model name") or info.get("Model") or platform.processor() or platform.machine()
    if "cpu family" in info:
        name += f" (family {info['cpu family']}, model {info.get('model', '?')}, stepping {info.get('stepping', '?')})"
    return name


def machine() -> dict:
    """The record: CPU model, logical CPUs, OS, Python, and the SIMD target the decoders run
    on (None where sssphere is not importable)."""
    try:
        import sssphere

        simd = sssphere.ScatteringModel.simd_target()
    except ImportError:
        simd = None
    return {"cpu": cpu_model(), "cpus": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "decoder_simd": simd}


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    print(json.dumps(machine(), indent=1))


if __name__ == "__main__":
    main()
