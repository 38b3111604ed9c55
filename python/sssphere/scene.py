"""Scene loading: one parser (the C++ one) for files, dicts and the command line."""

from __future__ import annotations

import contextlib
import copy
import errno
import json
import math
import os
import threading
import warnings
from pathlib import Path
from typing import Any, Union

import numpy as np

from sssphere import _core
from sssphere._core import SceneError


class SceneWarning(UserWarning):
    """A scene that renders, with something to say: past the limits of docs/robustness.md
    (float precision may make it differ from the exact answer by more than 1 %), a value
    taken for another (an ior within 0.01 of 1 is index-matched), or, from a render, a
    medium that integrator "st" renders without steps (its models were not trained for
    it)."""


_DELETE = object()  # _assign's value that removes a field


def _jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars and scene nodes as plain lists and numbers."""
    if isinstance(value, SceneNode):
        return value.to_python()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (str, os.PathLike)) and not isinstance(value, str):
        return os.fspath(value)
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def _field_name(path: tuple) -> str:
    """A path as the parser's messages name fields: shapes[0].medium.sigma_t."""
    out = ""
    for key in path:
        out += f"[{key}]" if isinstance(key, int) else (f".{key}" if out else key)
    return out


class Scene(_core.Scene):
    """A loaded scene, built (BVH, distance grids) and ready to render; load_scene makes
    one. Its fields can be changed in place, as in the scene file (docs/scene-format.md)::

        scene.shapes[0].medium.sigma_t = 800
        scene.camera.origin = [0, 1, 4]
        scene.lights[0] = {"type": "point", "position": [1, 2, 3], "intensity": 10}
        scene.render.spp = 64

    Each assignment is checked at once, with the scene file's messages (a SceneError; the
    scene is then unchanged), and rebuilds only what it must: the BVH when a shape's or an
    area light's geometry changed, a shape's distance grid when its mesh, its grid
    resolution or the opaque surfaces meeting it did (``rebuilt`` says what the last change
    built; lights other than area lights' quads, the camera and render settings build
    nothing, and so do materials unless
    the largest sigma_t crosses a threshold of the grid's resolution, which follows it:
    docs/notation.md, "Distance grid"). Mesh files are
    not read again unless they changed on disk. An edit while another thread renders the
    scene is refused (a SceneError): the render would see part of it. A render started
    during an edit waits for it, and so does one started while render_frames runs in
    another thread (it sets the camera between its frames), which starts once the renders
    running have returned.
    """

    def __init__(self, text: str, base_dir: str, source: str, threads: int = 0):
        meshes = _core.MeshCache()
        # Renders in progress (rendering.py counts them), the thread in render_frames (which
        # sets the camera between its renders) and the lock that keeps a rebuild and a
        # render apart.
        self._renders, self._editing = {}, threading.Condition()  # renders by thread
        self._posing = None
        super().__init__(text, base_dir, source, threads, meshes)
        self._meshes = meshes
        try:  # the text the C++ parser took, which skips one leading byte order mark
            self._doc = json.loads(text.removeprefix("\ufeff"))
        except ValueError as e:  # the two parsers disagree: say it as the C++ one would
            raise SceneError(f"{source}: malformed JSON: {e}") from None
        self._base_dir, self._source, self._threads = base_dir, source, threads
        self._stamps = _file_stamps(self._doc, base_dir)

    def __reduce__(self):
        """Pickled (and copied) as its scene text, base directory, source and threads: the
        copy is built again where it is loaded (multiprocessing, copy.deepcopy), reading the
        mesh files, which must be there too."""
        return (Scene, (json.dumps(self._doc), self._base_dir, self._source, self._threads))

    def __setattr__(self, name: str, value: Any) -> None:
        # A misspelt block (scene.lightz = [...]) would be a new attribute that changes
        # nothing: refused as the scene file's unknown keys are. Our own start with "_".
        if name.startswith("_") or hasattr(type(self), name):
            super().__setattr__(name, value)
            return
        source = self.__dict__.get("_source", "<scene>")
        raise SceneError(f"{source}: {name}: no such field in the scene (allowed: "
                         "camera, shapes, lights, render)")

    def __repr__(self) -> str:
        # A traceback shows the frame of an __init__ whose C++ half raised: not built.
        return super().__repr__() if "_doc" in self.__dict__ else "<sssphere.Scene (not built)>"

    # The scene file's top-level blocks, as editable nodes (assigning one replaces it).
    camera = property(lambda self: SceneNode(self, ("camera",)),
                      lambda self, value: self._assign(("camera",), value),
                      doc="The camera block, editable (docs/scene-format.md, camera).")
    shapes = property(lambda self: SceneNode(self, ("shapes",)),
                      lambda self, value: self._assign(("shapes",), value),
                      doc="The shapes list, editable (docs/scene-format.md, shapes).")
    lights = property(lambda self: SceneNode(self, ("lights",)),
                      lambda self, value: self._assign(("lights",), value),
                      doc="The lights list, editable (docs/scene-format.md, lights).")
    render = property(lambda self: SceneNode(self, ("render",)),
                      lambda self, value: self._assign(("render",), value),
                      doc="The render block, editable (docs/scene-format.md, render).")

    @contextlib.contextmanager
    def _rendered(self):
        """Held by a render of this scene: edits are refused meanwhile. While render_frames
        runs in another thread, it waits for it."""
        me = threading.get_ident()
        with self._editing:
            self._editing.wait_for(lambda: self._posing in (None, me))
            self._renders[me] = self._renders.get(me, 0) + 1
        try:
            yield self
        finally:
            with self._editing:
                self._renders[me] -= 1
                if not self._renders[me]:
                    del self._renders[me]
                self._editing.notify_all()

    @contextlib.contextmanager
    def _posed(self):
        """Held by render_frames, which sets the camera between its renders: it starts once
        the renders running (and another render_frames) have returned; meanwhile renders
        from other threads wait and their edits are refused."""
        me = threading.get_ident()
        with self._editing:
            nested = self._posing == me  # render_frames from render_frames' on_frame
            if not nested:
                self._editing.wait_for(lambda: self._posing is None and
                                       not set(self._renders) - {me})
                self._posing = me
        try:
            yield self
        finally:
            if not nested:
                with self._editing:
                    self._posing = None
                    self._editing.notify_all()

    def to_dict(self) -> dict:
        """The scene as a dict of the scene file's structure (a copy): load_scene(d,
        base_dir=scene.base_dir) builds the same scene."""
        return copy.deepcopy(self._doc)

    def _value(self, path: tuple, missing: type = AttributeError) -> Any:
        """The field at ``path``; raises ``missing`` (AttributeError for attributes,
        IndexError or KeyError for items) naming the field if it is not there."""
        value = self._doc
        for i, key in enumerate(path):
            try:
                value = value[key]
            except (KeyError, IndexError, TypeError):
                where = _field_name(path[:i + 1])
                raise missing(f"{self._source}: {where}: no such field in the scene"
                              + ("" if i else " (the default applies)")) from None
        return value

    def _assign(self, path: tuple, value: Any) -> None:
        """Sets (or, with _DELETE, removes) the field at ``path`` and rebuilds what the
        change needs; on an error the scene is unchanged."""
        value = value if value is _DELETE else _jsonable(value)
        bad = None if value is _DELETE else _find_bad_value(value, _field_name(path))
        if bad:
            raise SceneError(f"{self._source}: {bad}")
        with self._editing:  # the copy is taken here: another thread's edit is kept
            running = sum(self._renders.values())
            posing = self._posing not in (None, threading.get_ident())
            if running or posing:
                raise SceneError(
                    f"{self._source}: {_field_name(path)}: cannot be changed while the scene "
                    f"is being rendered ("
                    + (f"{running} render{'s' if running > 1 else ''} of it running"
                       if running else "render_frames in another thread")
                    + "): change it once the render has returned, or change a copy, "
                    "load_scene(scene.to_dict(), base_dir=scene.base_dir)")
            doc = copy.deepcopy(self._doc)
            node = doc
            for i, key in enumerate(path[:-1]):
                if isinstance(node, dict) and isinstance(key, str) and key not in node:
                    node[key] = [] if isinstance(path[i + 1], int) else {}
                try:
                    node = node[key]
                except (KeyError, IndexError, TypeError):
                    raise SceneError(f"{self._source}: {_field_name(path[:i + 1])}: no such "
                                     "field in the scene") from None
            key = path[-1]
            try:
                if value is _DELETE:
                    del node[key]
                elif isinstance(node, list) and key == len(node):
                    node.append(value)  # one past the end appends
                else:
                    node[key] = value
            except (KeyError, IndexError, TypeError):
                raise SceneError(f"{self._source}: {_field_name(path)}: no such field in the "
                                 "scene (a list grows by assigning at its length)") from None
            self._rebuild(json.dumps(doc), self._base_dir, self._source, self._threads,
                          self._meshes)
            self._doc = doc
            self._stamps = _file_stamps(doc, self._base_dir)
        _warned(self, stacklevel=4)


def _file_stamps(doc: Any, base_dir: str) -> dict:
    """{path: (size, modification time)} of the files the description reads (meshes,
    environment maps) as the scene was built from them. A cluster render sends those
    files to its workers and refuses one changed since (the scene holds the old one)."""
    stamps = {}
    for block, key in (("shapes", "mesh"), ("lights", "map")):
        items = doc.get(block) if isinstance(doc, dict) else None
        for item in items if isinstance(items, list) else []:
            path = item.get(key) if isinstance(item, dict) else None
            if isinstance(path, str):
                full = os.path.join(base_dir, path)
                with contextlib.suppress(OSError):
                    st = os.stat(full)
                    stamps[full] = (st.st_size, st.st_mtime_ns)
    return stamps


class SceneNode:
    """A block of an editable Scene (a dict or list of the scene file): fields read as
    attributes or items (nested blocks as nodes, numbers and strings as they are) and
    assigned the same way; ``to_python()`` gives a copy of the block; numpy reads a node
    of numbers (``np.asarray(scene.camera.origin)``)."""

    __slots__ = ("_scene", "_path")

    def __init__(self, scene: Scene, path: tuple):
        object.__setattr__(self, "_scene", scene)
        object.__setattr__(self, "_path", path)

    def _child(self, key, missing: type = AttributeError):
        value = self._scene._value(self._path + (key,), missing)
        return SceneNode(self._scene, self._path + (key,)) if isinstance(
            value, (dict, list)) else value

    def to_python(self) -> Any:
        """This part of the scene as plain Python (dicts, lists, numbers, strings): a copy."""
        return copy.deepcopy(self._scene._value(self._path))

    def __getattr__(self, name: str):
        if name.startswith("_"):  # ours are slots; no scene field starts with "_"
            raise AttributeError(name)
        return self._child(name)

    def __setattr__(self, name: str, value: Any) -> None:
        self._scene._assign(self._path + (name,), value)

    def __delattr__(self, name: str) -> None:
        self._scene._assign(self._path + (name,), _DELETE)

    def __getitem__(self, key):
        if isinstance(key, int) and key < 0:
            key += len(self)
        return self._child(key, IndexError if isinstance(key, int) else KeyError)

    def __setitem__(self, key, value: Any) -> None:
        if isinstance(key, int) and key < 0:
            key += len(self)
        self._scene._assign(self._path + (key,), value)

    def __delitem__(self, key) -> None:
        if isinstance(key, int) and key < 0:
            key += len(self)
        self._scene._assign(self._path + (key,), _DELETE)

    def __len__(self) -> int:
        return len(self._scene._value(self._path))

    def __iter__(self):
        value = self._scene._value(self._path)
        keys = range(len(value)) if isinstance(value, list) else list(value)
        return (self._child(k) if isinstance(value, list) else k for k in keys)

    def __contains__(self, key) -> bool:
        return key in self._scene._value(self._path)

    def keys(self):
        """The fields of this block, as in the scene file (an object's keys)."""
        return list(self._scene._value(self._path))

    def __eq__(self, other: Any) -> bool:
        return self.to_python() == _jsonable(other)

    __hash__ = None

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self._scene._value(self._path), dtype=dtype)

    def __repr__(self) -> str:
        return f"{_field_name(self._path)} = {json.dumps(self._scene._value(self._path))}"


def _warned(scene: Scene, stacklevel: int = 3) -> Scene:
    for message in scene.warnings:
        warnings.warn(message, SceneWarning, stacklevel=stacklevel)
    return scene


def _find_bad_value(value: Any, path: str) -> str | None:
    """What is wrong with the first value in a nested dict/list that JSON cannot state (a
    NaN or infinite number; a complex number, set or other object), as "field: problem",
    or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return f"{path}: value is not a finite number"
    if isinstance(value, dict):
        for k, v in value.items():
            found = _find_bad_value(v, f"{path}.{k}" if path else str(k))
            if found:
                return found
        return None
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            found = _find_bad_value(v, f"{path}[{i}]")
            if found:
                return found
        return None
    if value is None or isinstance(value, (bool, int, float, str)):
        return None
    return (f"{path}: a {type(value).__name__} is not a scene value (numbers, strings, "
            f"lists and objects are: docs/scene-format.md)")


def _threads(threads) -> int:
    """load_scene's threads as a render takes them: None or 0 (all cores) to 4096."""
    if threads is None:
        return 0
    if (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
            or not 0 <= threads <= 4096):
        raise SceneError(f"threads must be an integer from 0 to 4096 (0 = all cores), got "
                         f"{threads!r}")
    return int(threads)


def load_scene(
    scene: Union[str, os.PathLike, dict], base_dir: Union[str, os.PathLike, None] = None,
    threads: int | None = None,
) -> Scene:
    """Load and validate a scene, build its acceleration structures.

    Parameters
    ----------
    scene : path to a JSON scene file, or a dict with the same structure
        (docs/scene-format.md); in a dict, numpy arrays stand for lists (a shape's
        ``vertices`` and ``faces``, say).
    base_dir : directory that relative mesh paths in a dict are resolved against
        (default: the current directory). Ignored for files (their own directory is used).
    threads : worker threads for building distance grids (default: all cores).

    Raises
    ------
    SceneError (a ValueError) naming the file, the field, the value and what is allowed.
    KeyboardInterrupt on Ctrl-C, which stops the distance grids' build within milliseconds
    (reading the meshes and the BVH run to their end first).

    Warns
    -----
    SceneWarning where the scene goes past the precision limits of docs/robustness.md
    (also in ``Scene.warnings``).

    The Scene returned can be edited in place and rendered again (see Scene).
    """
    threads = _threads(threads)
    if isinstance(scene, dict):
        try:
            scene = _jsonable(scene)  # numpy arrays (e.g. a shape's vertices and faces)
            bad = _find_bad_value(scene, "")
            if bad:
                raise SceneError(f"<dict>: {bad}")
            text = json.dumps(scene)
        except RecursionError:
            raise SceneError("<dict>: nested too deeply (the scene format nests at most a few "
                             "levels)") from None
        base = str(base_dir) if base_dir is not None else os.getcwd()
        return _warned(Scene(text, base, "<dict>", threads))
    if not isinstance(scene, (str, os.PathLike)):
        raise TypeError(f"scene must be a path to a scene file, a dict or a Scene, got {scene!r}")
    if isinstance(scene, str) and scene.lstrip().startswith("{"):
        raise SceneError("scene: got JSON text, not a path to a scene file (pass "
                         "json.loads(text), a dict)")
    path = Path(scene)
    if not path.exists():
        try:
            path.stat()
        except OSError as e:
            if e.errno == errno.ELOOP:
                raise SceneError(f"{path}: is a loop of symbolic links, not a scene file") from None
        raise SceneError(f"{path}: scene file does not exist")
    if path.is_dir():
        raise SceneError(f"{path}: is a directory, not a scene file")
    if not path.is_file():  # a FIFO, device or socket would block the read
        raise SceneError(f"{path}: is not a regular file (a FIFO, device or socket?); a scene file "
                         "must be a regular file")
    try:
        text = _scene_text(path)
    except OSError as e:
        raise SceneError(f"{path}: scene file cannot be read: {e}") from None
    except MemoryError:
        raise SceneError(f"{path}: scene file of {path.stat().st_size} bytes does not fit in "
                         "memory") from None
    return _warned(Scene(text, str(path.parent), str(path), threads))


def _scene_text(path: Path) -> Union[str, bytes]:
    """A scene file's text; its bytes where they are not UTF-8, for the parser to say where
    (line, column and field, as sssphere-render does), not Python's codec."""
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data


def load_mesh(path: Union[str, os.PathLike]) -> tuple[np.ndarray, np.ndarray]:
    """Load, check and orient a closed mesh. Returns (vertices (n, 3) float32,
    triangles (m, 3) uint32), counter-clockwise = outward."""
    return _core.load_mesh(str(path))


def presets() -> list[dict]:
    """The measured media a scene's ``"preset"`` names (docs/scene-format.md, "Ways to state a
    medium"): one dict per medium with ``name``, ``sigma_s_prime`` (reduced scattering) and
    ``sigma_a`` (absorption), RGB in mm^-1, ``ior`` (the source's index of refraction, or
    None) and ``source``. A preset medium gets sigma_s = sigma_s_prime / (1 - g) for its own
    ``g``, times its ``scale`` (scene units per mm). Numbers are given as published (2.29,
    not the 2.2899999618530273 of the float32 the renderer holds)."""
    def published(v):  # the shortest decimal that rounds to the same float32
        return None if v is None else float(str(np.float32(v)))

    out = []
    for p in _core.medium_presets():
        p = dict(p)
        p["sigma_s_prime"] = [published(v) for v in p["sigma_s_prime"]]
        p["sigma_a"] = [published(v) for v in p["sigma_a"]]
        p["ior"] = published(p["ior"])
        out.append(p)
    return out


def load_scene_with(path: Union[str, os.PathLike], assignments: list[str] | None = None,
                    width: int | None = None, height: int | None = None,
                    threads: int | None = None) -> Scene:
    """A scene file with the command line's changes: ``--set PATH=VALUE`` assignments (PATH
    as the parser's messages name fields, e.g. ``shapes[0].medium.sigma_t``; VALUE is JSON,
    else a string), then the image size (one of width and height alone keeps the camera's
    aspect ratio). The same code as `sssphere-render`'s (render/scene.h, edit_scene_json);
    errors name the file, as for the file itself."""
    if not assignments and width is None and height is None:
        return load_scene(path, threads=threads)
    path = Path(path)
    if not path.is_file():
        return load_scene(path, threads=threads)  # says what is wrong with the path
    try:
        text = _scene_text(path)
    except (OSError, MemoryError):
        return load_scene(path, threads=threads)  # says what is wrong with the file
    text = _core.edit_scene_json(text, str(path), list(assignments or []), width or 0,
                                 height or 0)
    threads = _threads(threads)
    return _warned(Scene(text, str(path.parent), str(path), threads))
