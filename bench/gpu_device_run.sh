#!/usr/bin/env bash
# Runs on a GPU machine (the device tool), in a copy of the repository with .devbench/
# (bench/gpu_st_vs_pt.py bake) and .gl/ (the Debian libvulkan1 package) carried along:
# unpacks the Vulkan loader, renders every baked run with sssphere-gpu-bench, and leaves
# the JSON lines and the images (one .npz) in $OUT for bench/gpu_st_vs_pt.py report.
set -euo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -f "$icd" ]; then export VK_DRIVER_FILES="$icd"; fi
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv || true
cd .devbench
for f in *.gz; do gunzip -kf "$f"; done
mkdir -p images
spp=$(cat spp.txt)
./sssphere-gpu-bench --spp "$spp" --batch "${BATCH:-0}" --lanes "${LANES:-0}" --repeat "${REPEAT:-3}" \
  --steps "${STEPS:-0}" --out images ${RUNS:-$(cat runs.txt)} \
  | tee "$OUT/gpu_bench.jsonl"
python3 - "$OUT/images.npz" <<'PY'
import sys, glob, os
import numpy as np
arrays = {os.path.basename(f)[:-4]: np.fromfile(f, dtype=np.float32) for f in glob.glob("images/*.f32")}
np.savez_compressed(sys.argv[1], **arrays)
PY
