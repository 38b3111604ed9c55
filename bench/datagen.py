#!/usr/bin/env python3
"""Training-data generation speed: `sssphere datagen` for 4M samples (target: under 10
minutes on the 2-core CI machine; the published C# generator needed 12-24 hours).

Runs the generator exactly as `sssphere datagen` does (same parameter sampling, same chunks)
and records wall time, walks/s and scattering events/s. The total number of events is the
measure of work: it depends on the (σ, g) sampling, documented in docs/learning.md.

    python -m bench.datagen                       # 4,000,000 samples
    python -m bench.datagen --samples 200000      # a quick run
    python -m bench.datagen --keep data.npz       # also save the data (for `sssphere train`)

Writes bench/results/datagen.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import time
from pathlib import Path

import numpy as np

from sssphere.learn import datagen
from bench.machine import machine


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=4_000_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=0, help="0 = all cores")
    ap.add_argument("--keep", help="save the generated data to this .npz file")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "datagen.json"))
    args = ap.parse_args()

    load_at_start = os.getloadavg()[0]
    t0 = time.monotonic()
    data, interrupted = datagen.generate(args.samples, seed=args.seed, threads=args.threads)
    seconds = time.monotonic() - t0
    if interrupted:
        raise SystemExit("interrupted")
    events = int(data["N"].sum())
    result = {
        "benchmark": "datagen",
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": {**machine(), "load_average_at_start": load_at_start},
        "samples": args.samples,
        "seed": args.seed,
        "threads": args.threads or os.cpu_count(),
        "seconds": round(seconds, 2),
        "walks_per_second": round(args.samples / seconds),
        "scattering_events": events,
        "ns_per_event_per_thread": round(seconds * (args.threads or os.cpu_count()) / events * 1e9, 2),
        "mean_N": float(data["N"].mean()),
        "fraction_N1": float(np.mean(data["N"] == 1)),
        "target_seconds": 600,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    if args.keep:
        datagen.save(args.keep, data, args.seed, seconds)
        print(f"saved {args.keep}")


if __name__ == "__main__":
    main()
