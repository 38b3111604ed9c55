# The one version string: the wheel's metadata (pyproject.toml reads it), CMake's project
# version and `sssphere-render --version` (CMakeLists.txt reads it), `sssphere.__version__`
# and `sssphere --version`.
__version__ = "0.2.0"
