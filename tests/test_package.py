"""The package as a user meets it: what `import sssphere` loads, and one version everywhere."""

import importlib
import importlib.metadata
import json
import re
import subprocess
import sys
from pathlib import Path

import sssphere
from test_cli import _cpp_cli, run_cli

REPO = Path(__file__).resolve().parents[1]


def _loaded_after(code: str) -> dict:
    """Run `code` in a fresh interpreter; which of the heavy parts were loaded after it."""
    probe = code + """
import json, sys
maps = open("/proc/self/maps").read()
print(json.dumps({
    "openimageio": "libOpenImageIO" in maps,
    "torch": any(m == "torch" or m.startswith("torch.") for m in sys.modules),
    "modules": sorted(m for m in sys.modules if m.startswith("sssphere")),
}))
"""
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return json.loads(r.stdout.splitlines()[-1])


def test_import_loads_neither_openimageio_nor_torch(tmp_path):
    after_import = _loaded_after("import sssphere")
    assert not after_import["openimageio"] and not after_import["torch"], after_import
    assert after_import["modules"] == ["sssphere", "sssphere._version"], after_import
    # ... and the probe sees them once they are used: the first image written loads OpenImageIO
    out = tmp_path / "x.exr"
    after_write = _loaded_after(f"import numpy, sssphere; sssphere.write_image({str(out)!r}, numpy.ones((2, 2, 3)))")
    assert after_write["openimageio"] and "sssphere._image" in after_write["modules"], after_write
    after_learn = _loaded_after("import sssphere.learn.models")
    assert after_learn["torch"], after_learn


def test_public_names_resolve_lazily_to_the_api():
    for name in sssphere.__all__:
        assert getattr(sssphere, name) is not None, name
    rendering = importlib.import_module("sssphere.rendering")  # must not shadow the function
    assert sssphere.render is rendering.render
    assert set(sssphere.__all__) <= set(dir(sssphere))


def test_one_version_everywhere():
    version = sssphere.__version__
    assert re.fullmatch(r"\d+\.\d+\.\d+([.-]?(a|b|rc|dev|post)\d+)?", version), version
    assert importlib.metadata.version("sssphere") == version
    assert run_cli("--version").stdout.strip() == f"sssphere {version}"
    r = subprocess.run([_cpp_cli(), "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == f"sssphere-render {version}", r
    cff = (REPO / "CITATION.cff").read_text()
    assert re.search(r"^version: (\S+)$", cff, re.M).group(1) == version
