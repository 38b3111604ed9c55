#!/usr/bin/env bash
# Checks the package as it is distributed: builds the sdist, builds a wheel from that sdist
# (so the sdist holds everything the build needs), installs the wheel into a new, empty
# virtual environment, and renders a small scene there with both command lines, the learned
# models (shipped inside the wheel) included. Needs the Debian libraries (install.sh).
#   bash scripts/check_dist.sh [PYTHON]   (default: python3; any interpreter >= 3.10)
set -euo pipefail
cd "$(dirname "$0")/.."
py=${1:-python3}
work=$(mktemp -d "${TMPDIR:-/tmp}/sssphere-dist.XXXXXX")
trap 'rm -rf "$work"' EXIT
say() { echo "check_dist.sh: $*"; }

"$py" -m venv "$work/build-env"
"$work/build-env/bin/python" -m pip install -q --disable-pip-version-check build
say "building the sdist"
"$work/build-env/bin/python" -m build -q --sdist -o "$work/dist" . >/dev/null
sdist=$(ls "$work"/dist/sssphere-*.tar.gz)
say "building a wheel from $(basename "$sdist") (a few minutes on 2 cores)"
"$work/build-env/bin/python" -m pip wheel -q --disable-pip-version-check --no-deps \
    -w "$work/dist" "$sdist"
wheel=$(ls "$work"/dist/sssphere-*.whl)

say "installing $(basename "$wheel") into an empty virtual environment"
"$py" -m venv "$work/env"
"$work/env/bin/python" -m pip install -q --disable-pip-version-check "$wheel"
cd "$work"   # away from the checkout: nothing may come from the source tree
cat > scene.json <<'JSON'
{"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 30,
            "width": 24, "height": 16},
 "shapes": [{"name": "ball", "sphere": {"center": [0, 0, 0], "radius": 1, "subdivisions": 3},
             "medium": {"sigma_t": [20, 20, 20], "albedo": [0.95, 0.9, 0.8], "g": 0.3},
             "boundary": {"type": "dielectric", "ior": 1.5}}],
 "lights": [{"type": "environment", "radiance": [1, 1, 1]}],
 "render": {"spp": 4, "seed": 1}}
JSON
version=$("$work/env/bin/python" -c "import sssphere; print(sssphere.__version__)")
[ "$("$work/env/bin/sssphere" --version)" = "sssphere $version" ]
[ "$("$work/env/bin/sssphere-render" --version)" = "sssphere-render $version" ]
"$work/env/bin/sssphere" render scene.json -o py.png --integrator st --quiet
"$work/env/bin/sssphere-render" scene.json -o cpp.exr --integrator st --quiet
"$work/env/bin/python" - <<'PY'
import numpy as np, sssphere
for name in ("py.png", "cpp.exr"):
    image = sssphere.read_image(name)
    assert image.shape == (16, 24, 3) and np.isfinite(image).all() and image.max() > 0, name
PY
say "passed: sdist -> wheel -> clean venv renders with sssphere and sssphere-render ($version)"
