"""The Python API: shapes, dtypes, determinism, partial renders, image files."""

import inspect
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sssphere
from sssphere import _core

from render_stats import block_z

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_render_returns_linear_float_image(small_scene):
    img = sssphere.render(sssphere.load_scene(small_scene), spp=4)
    assert img.shape == (16, 24, 3)
    assert img.dtype == np.float32
    assert np.all(np.isfinite(img)) and np.all(img >= 0)
    # A corner ray misses the sphere and sees the environment's radiance exactly.
    np.testing.assert_array_equal(img[0, 0], np.float32(0.1))


def test_same_seed_same_image_any_threads_and_scene_defaults(small_scene):
    scene = sssphere.load_scene(small_scene)
    a = sssphere.render(scene, threads=1)  # spp and seed from the scene's render block
    b = sssphere.render(scene, threads=2)
    c = sssphere.render(scene, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_render_full_gives_variance_and_complexity(small_scene):
    r = sssphere.render_full(small_scene, spp=8)
    assert r.variance.shape == (16, 24, 3) and np.all(r.variance >= 0)
    assert r.events.shape == (16, 24)
    assert np.all(r.samples == 8)
    # Paths that hit the sphere scatter; background paths do not.
    assert r.events[8, 12] > 1 and r.events[0, 0] == 0
    assert r.mean_events_per_path > 0 and not r.interrupted


def test_render_takes_the_options_pages_options_as_render_full_does(small_scene):
    """docs/options.md's table is the render options (render_option_specs), each a keyword
    of render_full and of render, but record_paths, which the page says is render_full's
    alone (render returns only the image); render's images are render_full's."""
    with open(os.path.join(REPO, "docs", "options.md"), encoding="utf-8") as f:
        page = f.read()
    table = set(re.findall(r"^\| `(\w+)` \| (?:choice|integer|flag|number|text) \|", page, re.M))
    assert table == {spec["name"] for spec in _core.render_option_specs()}
    assert table <= set(inspect.signature(sssphere.render_full).parameters)
    assert table - set(inspect.signature(sssphere.render).parameters) == {"record_paths"}
    assert "`record_paths` is `render_full`'s alone" in page
    scene = sssphere.load_scene(small_scene)
    assert not np.array_equal(sssphere.render(scene, spp=1, max_bounces=0), sssphere.render(scene, spp=1))
    for options in ({"max_bounces": 0}, {"integrator": "st", "sphere_sampler": "walk"},
                    {"integrator": "st", "cut_models": os.path.join(REPO, "models", "cut")}):
        np.testing.assert_array_equal(sssphere.render(scene, spp=1, **options),
                                      sssphere.render_full(scene, spp=1, **options).image)
    with pytest.raises(TypeError, match=r"render\(\) takes no 'record_paths': render_full\(scene, "
                                        r"record_paths=True\) returns the image with every path's"):
        sssphere.render(scene, record_paths=True)
    with pytest.raises(TypeError, match="unexpected keyword argument 'max_bounce' .* max_bounces,"):
        sssphere.render(scene, max_bounce=0)
    # render's first four positions stay; the next was nee, and is keyword-only now
    np.testing.assert_array_equal(sssphere.render(scene, "pt", 1, 2, 1),
                                  sssphere.render(scene, integrator="pt", spp=1, seed=2))
    with pytest.raises(TypeError, match="too many positional arguments"):
        sssphere.render(scene, "pt", 1, 2, 1, False)


def _stopped_after(small_scene, calls, **options):
    """A render of 2^14 spp of a dense ball that the progress callback stops at its
    `calls`-th call; returns the result and the fractions the callback saw."""
    small_scene["render"]["spp"] = 1 << 14
    small_scene["shapes"][0]["medium"]["sigma_t"] = 200
    seen = []

    def progress(fraction):
        seen.append(fraction)
        return len(seen) < calls

    return sssphere.render_full(small_scene, progress=progress, **options), seen


def test_progress_callback_can_stop_early(small_scene):
    r, seen = _stopped_after(small_scene, 2)
    assert r.interrupted
    assert r.samples.sum() < (1 << 14) * r.samples.size
    assert np.all(np.isfinite(r.image))
    assert all(0 <= f <= 1 for f in seen)


def test_a_progress_callback_returns_a_truth_value(small_scene):
    """True, False, None, or NumPy's bool; anything else is a mistake said in one line
    (it was pybind11's "Unable to cast Python instance of type <class 'str'>")."""
    assert not sssphere.render_full(small_scene, spp=2, progress=lambda f: np.True_).interrupted
    with pytest.raises(TypeError, match="progress callback must return True, False or None .*got 'no'"):
        sssphere.render_full(small_scene, spp=2, progress=lambda f: "no")


_RENDER_IN_A_DAEMON_THREAD_AT_EXIT = """
import sys, threading, time
import sssphere
scene = sssphere.load_scene(sys.argv[1])
started = threading.Event()
def work():
    started.set()
    sssphere.render_full(scene, spp=1 << 24, threads=1)
threading.Thread(target=work, daemon=True).start()
started.wait()
time.sleep(1)
print("exiting", flush=True)
"""


@pytest.mark.parametrize("threads_of_the_render", [1, 2])
def test_python_exiting_under_a_render_in_a_daemon_thread_is_a_clean_exit(tmp_path, small_scene,
                                                                          threads_of_the_render):
    """Python ends a daemon thread that takes the GIL after it began to exit (pthread_exit).
    The render's progress callback took it, the unwinding met a catch-all in the scheduler
    and a destructor that took the GIL again: the process aborted (SIGABRT or SIGSEGV)."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    code = _RENDER_IN_A_DAEMON_THREAD_AT_EXIT.replace("threads=1", f"threads={threads_of_the_render}")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "s.json")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout == "exiting\n", (r.returncode, r.stdout, r.stderr)


@pytest.mark.parametrize("integrator", ["pt", "st"])
def test_a_stop_ends_paths_that_would_not_end_for_hours(tmp_path, integrator):
    """sigma_t = 1e7 per unit in a unit ball of albedo 1 behind glass: a path takes about
    1e14 events. A stop was checked only between paths, so neither Ctrl-C nor SIGTERM ended
    such a render (it had to be killed). Now the first pass is stopped mid-path: nothing
    is kept (no pass finished). Run in a child so that a regression fails, not hangs."""
    scene = {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 30, "width": 8,
                        "height": 8},
             "shapes": [{"sphere": {"center": [0, 0, 0], "radius": 1},
                         "medium": {"sigma_t": 1e7, "albedo": 1, "g": 0.5},
                         "boundary": {"type": "dielectric", "ior": 1.5}}],
             "lights": [{"type": "environment", "radiance": 1}]}
    (tmp_path / "s.json").write_text(json.dumps(scene))
    code = ("import sys, time, sssphere\n"
            "t0 = time.monotonic()\n"
            f"r = sssphere.render_full(sys.argv[1], spp=1, integrator='{integrator}',\n"
            "                          progress=lambda f: time.monotonic() - t0 < 1)\n"
            "print(r.interrupted, r.spp, round(time.monotonic() - t0, 1))\n")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "s.json")],
                       capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stderr
    interrupted, spp, _seconds = r.stdout.split()
    assert (interrupted, spp) == ("True", "0"), r.stdout


# Run in a child: the same call twice, whole and then with SIGINT half a second in; prints
# both times. A call that ignores the signal runs to its end and raises KeyboardInterrupt
# only then, so the second time tells a stop from a finish.
_CTRL_C_CHILD = """
import os, signal, sys, threading, time, sssphere
signal.signal(signal.SIGINT, signal.default_int_handler)  # even if started ignoring it
call = eval(sys.argv[1])
t0 = time.monotonic()
call()
whole = time.monotonic() - t0
threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
t0 = time.monotonic()
try:
    call()
    print("finished", whole, time.monotonic() - t0)
except KeyboardInterrupt:
    print("interrupted", whole, time.monotonic() - t0)
"""


@pytest.mark.parametrize("what", ["load_scene", "scene_edit", "first_hit_aovs"])
def test_ctrl_c_stops_a_long_load_and_long_aovs(tmp_path, small_scene, what):
    """A scene's distance grids (a 384-cell grid on one thread: seconds; 512 cells on a
    fine mesh: minutes), built by a load or by an edit, and first_hit_aovs of many samples
    ran to their end whatever Ctrl-C said. All now stop at their next poll and raise
    KeyboardInterrupt."""
    small_scene["render"]["grid_resolution"] = 384
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    call = {"load_scene": f"lambda: sssphere.load_scene({str(tmp_path / 's.json')!r}, threads=1)",
            "scene_edit": "lambda s=sssphere.load_scene(sys.argv[2], threads=1), "
                          "r=iter([384, 383]): setattr(s.render, 'grid_resolution', next(r))",
            "first_hit_aovs": "lambda s=sssphere.load_scene(sys.argv[2]): "
                              "sssphere.first_hit_aovs(s, samples=1 << 17, threads=1)"}[what]
    if what != "load_scene":  # loaded quickly before the timed calls
        small_scene["render"]["grid_resolution"] = 16
        (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = subprocess.run([sys.executable, "-c", _CTRL_C_CHILD, call, str(tmp_path / "s.json")],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    outcome, whole, stopped = r.stdout.split()
    assert outcome == "interrupted", r.stdout
    assert float(whole) > 2, r.stdout  # long enough for a stop at 0.5 s to tell
    assert float(stopped) < 0.5 * float(whole), r.stdout


def test_record_paths_gives_every_paths_counts(small_scene):
    scene = sssphere.load_scene(small_scene)
    assert sssphere.render_full(scene, spp=2).path_events is None
    a = sssphere.render_full(scene, spp=6, seed=3, threads=1, record_paths=True)
    b = sssphere.render_full(scene, spp=6, seed=3, threads=2, record_paths=True)
    assert a.path_events.shape == a.path_steps.shape == (6, 16, 24)
    assert a.path_events.dtype == np.uint32
    np.testing.assert_array_equal(a.path_events, b.path_events)
    # The per-pixel means are the recorded paths' means; pt takes no sphere steps.
    np.testing.assert_allclose(a.path_events.mean(axis=0), a.events, rtol=1e-6)
    assert a.path_events.mean() == pytest.approx(a.mean_events_per_path, rel=1e-12)
    assert not a.path_steps.any()
    # Paths differ: the samples of one pixel are not copies of each other.
    assert len(np.unique(a.path_events[:, 8, 12])) > 1


def test_record_paths_of_an_interrupted_render_are_zero_past_its_samples(small_scene):
    small_scene["render"]["spp"] = 1 << 10
    small_scene["shapes"][0]["medium"]["sigma_t"] = 200
    r = sssphere.render_full(small_scene, record_paths=True, progress=lambda f: False)
    assert r.interrupted
    k = np.arange(1 << 10)[:, None, None]
    assert not r.path_events[k >= r.samples[None]].any()
    taken = k < r.samples[None]
    if taken.any():
        np.testing.assert_allclose(np.where(taken, r.path_events, 0).sum(axis=0),
                                   r.events * r.samples, rtol=1e-5)


def test_record_paths_refuses_more_paths_than_it_can_hold(small_scene):
    with pytest.raises(sssphere.SceneError, match=r"record_paths keeps 8 bytes per path: 24x16 "
                       r"pixels at 349526 spp are 134217984 paths \(allowed: at most 134217728\)"):
        sssphere.render_full(small_scene, spp=349526, record_paths=True)
    # a time limit alone leaves spp unlimited: the message says so, and what to do
    del small_scene["render"]["spp"]
    with pytest.raises(sssphere.SceneError, match=r"under a time limit spp is the most the render "
                       r"takes, unlimited unless given: give spp"):
        sssphere.render_full(small_scene, time_limit=1, record_paths=True)
    assert sssphere.render_full(small_scene, time_limit=1, spp=2, record_paths=True).spp == 2
    with pytest.raises(sssphere.SceneError, match="record_paths must be True or False"):
        sssphere.render_full(small_scene, spp=1, record_paths="yes")


def test_write_exr_keeps_linear_values_and_png_is_srgb(tmp_path, small_scene):
    img = np.zeros((4, 5, 3), np.float32)
    img[1, 2] = [2.5, 0.5, 0.0]
    sssphere.write_image(tmp_path / "a.exr", img)
    sssphere.write_image(tmp_path / "a.png", img)
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "a.exr"), img)
    png = sssphere.read_image(tmp_path / "a.png")  # as 8-bit sRGB values / 255
    assert png.shape == (4, 5, 3)
    srgb_half = 1.055 * 0.5 ** (1 / 2.4) - 0.055
    np.testing.assert_allclose(png[1, 2], [1.0, round(255 * srgb_half) / 255, 0.0])


def test_load_scene_from_file_resolves_mesh_relative_to_it(tmp_path, small_scene):
    scene = sssphere.load_scene(small_scene)
    v, f = scene.shape_mesh(0)
    lines = ["OFF", f"{len(v)} {len(f)} 0"] + [" ".join(map(str, p)) for p in v] + [
        "3 " + " ".join(map(str, t)) for t in f]
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "ball.off").write_text("\n".join(lines) + "\n")
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = "meshes/ball.off"
    (tmp_path / "scene.json").write_text(json.dumps(small_scene))
    s2 = sssphere.load_scene(tmp_path / "scene.json")
    assert "scene.json" in repr(s2)
    np.testing.assert_allclose(sssphere.render(s2), sssphere.render(scene), rtol=1e-5, atol=1e-6)


AREA_LIGHT = {"type": "area", "corner": [-2, 1.5, 2], "edge1": [0, 0, -4], "edge2": [4, 0, 0],
              "radiance": [1, 1, 1]}
ENVIRONMENT = {"type": "environment", "radiance": [1, 0.5, 0.25]}


FLOOR = {"mesh": str(Path(__file__).resolve().parents[1] / "scenes" / "meshes" / "floor.obj"),
         "transform": {"scale": 8, "translate": [0, -1.05, 0]},
         "surface": {"type": "diffuse", "reflectance": [0.8, 0.6, 0.4]}}


@pytest.mark.parametrize("lights, floor",
                         [([AREA_LIGHT], False), ([ENVIRONMENT], False),
                          ([AREA_LIGHT, ENVIRONMENT], False), ([AREA_LIGHT, ENVIRONMENT], True)],
                         ids=["area", "environment", "area+environment", "floor"])
def test_nee_with_mis_agrees_with_plain_path_tracing(small_scene, lights, floor):
    """Light sampling + MIS (the default) and pure phase sampling estimate the same image.

    An area light above an index-matched sphere catches MIS weights measured from the wrong
    point; two lights catch a light-selection probability missing from (or counted twice in)
    the weights; a diffuse floor under the sphere, seen from above, the same at surface
    vertices (BSDF sampling against light sampling). The test compares 4x4 block means by a
    chi-square test on their z-scores.
    """
    from scipy import stats

    small_scene["lights"] = lights
    if floor:
        small_scene["shapes"].append(FLOOR)
        small_scene["camera"]["origin"] = [0, 2.5, 4]
    small_scene["shapes"][0]["medium"].update(sigma_t=[1, 1, 1], albedo=[0.9, 0.9, 0.9], g=0.0)
    scene = sssphere.load_scene(small_scene)
    with_nee = sssphere.render_full(scene, spp=256, seed=1)
    without = sssphere.render_full(scene, spp=1024, seed=2, nee=False)
    for c, z in enumerate(block_z(with_nee, without)):
        n = z.size
        assert n > 8
        chi2 = float((z ** 2).sum())
        assert stats.chi2.sf(chi2, n) > 1e-3, f"channel {c}: chi2 {chi2:.1f} over {n} blocks"
        assert np.abs(z).max() < stats.norm.isf(1e-3 / (2 * n)), (c, np.abs(z).max())


def test_a_stopped_render_keeps_whole_passes_so_every_pixel_has_its_first_samples(small_scene):
    r, _ = _stopped_after(small_scene, 4, seed=5, threads=2)
    assert r.interrupted and not r.time_limit_reached
    assert 0 < r.spp < 1 << 14
    assert np.all(r.samples == r.spp)
    # The same samples as a render of r.spp from the start: pixel means agree to rounding
    # (the passes group the sums differently).
    full = sssphere.render_full(small_scene, spp=r.spp, seed=5, threads=1)
    np.testing.assert_allclose(r.image, full.image, rtol=1e-5, atol=1e-7)
    assert r.mean_events_per_path == pytest.approx(full.mean_events_per_path, rel=1e-12)


def test_time_limit_stops_with_whole_passes_and_reports_the_spp_reached(small_scene):
    small_scene["shapes"][0]["medium"]["sigma_t"] = 200
    scene = sssphere.load_scene(small_scene)
    del small_scene["render"]["spp"]
    # No spp given: the time alone ends it (spp would otherwise be 2**24, hours here).
    r = sssphere.render_full(dict(small_scene, render={"time_limit": 0.5}), seed=2)
    assert r.time_limit_reached and not r.interrupted
    assert r.options["time_limit"] == 0.5 and r.options["spp"] == 1 << 24
    assert 1 <= r.spp < 1 << 24 and np.all(r.samples == r.spp)
    assert r.seconds < 30  # stopped, not run to 2**24 spp
    full = sssphere.render_full(scene, spp=r.spp, seed=2)
    np.testing.assert_allclose(r.image, full.image, rtol=1e-5, atol=1e-7)
    # A limit not reached changes nothing but the grouping of the sums.
    unhurried = sssphere.render_full(scene, spp=8, seed=2, time_limit=600)
    assert not unhurried.time_limit_reached and unhurried.spp == 8
    np.testing.assert_allclose(unhurried.image, sssphere.render_full(scene, spp=8, seed=2).image,
                               rtol=1e-6, atol=0)


def test_time_limit_is_checked(small_scene):
    scene = sssphere.load_scene(small_scene)
    for bad in (-1, float("inf"), "1"):
        with pytest.raises(ValueError, match="time_limit must be a number from 0 to 1e9"):
            sssphere.render_full(scene, time_limit=bad)
    small_scene["render"]["time_limit"] = -2
    with pytest.raises(sssphere.SceneError, match=r"render\.time_limit.*0 \(no limit\) to 1e9"):
        sssphere.load_scene(small_scene)


def test_images_show_and_save_themselves(tmp_path, small_scene):
    """Notebooks: render() returns an Image (a numpy array) and render_full() a RenderResult,
    both with _repr_png_ (what Jupyter displays: the PNG the .png output writes) and save()
    (.exr exact, .png sRGB; a result's AOVs beside it)."""
    scene = sssphere.load_scene(small_scene)
    img = sssphere.render(scene, spp=2, seed=4)
    assert isinstance(img, np.ndarray) and isinstance(img, sssphere.Image)
    png = img._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    (tmp_path / "shown.png").write_bytes(png)
    sssphere.write_image(tmp_path / "written.png", np.asarray(img))
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "shown.png"),
                                  sssphere.read_image(tmp_path / "written.png"))
    img.save(tmp_path / "img.exr")
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "img.exr"), img)

    r = sssphere.render_full(scene, spp=2, seed=4)
    assert r._repr_png_() == png
    written = r.save(tmp_path / "r.png", aovs=True)  # an .exr holds them all (test_everyday)
    assert [os.path.basename(p) for p in written] == ["r.png", "r_variance.exr", "r_events.exr"]
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "r.png"),
                                  sssphere.read_image(tmp_path / "written.png"))
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "r_variance.exr"), r.variance)
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "r_events.exr")[..., 0],
                                  r.events)


def test_scene_and_progress_arguments_of_the_wrong_kind_are_named(small_scene):
    with pytest.raises(TypeError, match="scene must be a path to a scene file, a dict or a Scene, got None"):
        sssphere.render(None)
    with pytest.raises(sssphere.SceneError, match="got JSON text, not a path"):
        sssphere.load_scene(json.dumps(small_scene))  # was OSError: File name too long
    with pytest.raises(TypeError, match="progress must be a function of the fraction done"):
        sssphere.render_full(small_scene, progress=1)
    for threads in (-1, 5000, "a"):  # -1 was taken, 'a' was int()'s message
        with pytest.raises(sssphere.SceneError, match="threads must be an integer from 0 to 4096"):
            sssphere.load_scene(small_scene, threads=threads)


def test_a_scene_pickles_and_copies_as_its_text(small_scene):
    """multiprocessing and copy.deepcopy need a Scene to pickle: it travels as its scene text
    (with the edits made to it) and is built again where it lands."""
    import copy
    import pickle

    scene = sssphere.load_scene(small_scene)
    scene.shapes[0].medium.sigma_t = 7
    for twin in (pickle.loads(pickle.dumps(scene)), copy.copy(scene), copy.deepcopy(scene)):
        assert isinstance(twin, sssphere.Scene) and twin is not scene
        assert twin.shapes[0].medium.sigma_t == 7
        np.testing.assert_array_equal(sssphere.render(twin, spp=2), sssphere.render(scene, spp=2))
