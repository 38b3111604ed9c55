"""The command-line renderers: `sssphere render` (Python) and `sssphere-render` (C++)."""

import copy
import json
import os
import pty
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import sssphere
from sssphere import _core

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args, **kwargs):
    return subprocess.run([sys.executable, "-m", "sssphere.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300, **kwargs)


def test_render_scene_file_to_exr_and_png(tmp_path, small_scene):
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("render", tmp_path / "s.json", "-o", tmp_path / "out.exr", "--spp", 3)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stderr and "3 spp" in r.stderr
    img = sssphere.read_image(tmp_path / "out.exr")
    expected = sssphere.render_full(sssphere.load_scene(small_scene), spp=3, aovs=True)
    np.testing.assert_array_equal(img, expected.image)
    r = run_cli("render", tmp_path / "s.json", "-o", tmp_path / "out.png", "--quiet")
    assert r.returncode == 0 and sssphere.read_image(tmp_path / "out.png").shape == (16, 24, 3)
    # --aovs: one multilayer EXR, the same layers from both command lines.
    for cli, name in ((run_cli, "py.exr"), (lambda *a: subprocess.run(
            [_cpp_cli(), *map(str, a[1:])], capture_output=True, text=True, timeout=300),
            "cpp.exr")):
        r = cli("render", tmp_path / "s.json", "-o", tmp_path / name, "--spp", 3, "--aovs",
                "--quiet")
        assert r.returncode == 0, r.stderr
        assert "no estimate of the variance" not in r.stderr
        # at 1 spp the variance layer is 0: not "no noise", and both say so
        one = cli("render", tmp_path / "s.json", "-o", tmp_path / f"one_{name}", "--spp", 1,
                  "--aovs", "--quiet")
        assert one.returncode == 0, one.stderr
        assert ("warning: variance: one sample per pixel gives no estimate of the variance"
                in one.stderr), one.stderr
        layers = sssphere.read_layers(tmp_path / name)
        assert sorted(layers) == ["", "albedo", "depth", "events", "normal", "variance"]
        np.testing.assert_array_equal(layers[""], expected.image)
        np.testing.assert_array_equal(layers["normal"], expected.normal)
        np.testing.assert_array_equal(layers["depth"][..., 0], expected.depth)
    assert not (tmp_path / "py_variance.exr").exists()
    with pytest.raises(sssphere.SceneError, match="read_layers"):
        sssphere.read_image(tmp_path / "py.exr")


@pytest.mark.parametrize(
    "args, expected",
    [
        (["render", "{scene}", "-o", "{tmp}/x.jpg"], "unsupported image format '.jpg'"),
        (["render", "{tmp}/none.json", "-o", "{tmp}/x.exr"], "none.json: scene file does not exist"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--spp", "0"], "--spp must be an integer >= 1"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--integrator", "mc"], "integrator 'mc' is not allowed"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--integrator", "st", "--models", "{tmp}/none"],
         "none: not a directory"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--sphere-threshold", "-1"], "must be a number >= 0"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--step-nee", "paper"],
         "--step-nee 'paper' is not allowed (allowed: 'hits', 'event')"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", "shapes[2].medium.sigma_t=1"],
         "--set shapes[2].medium.sigma_t: shapes has 1 entries, no [2]"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", "shapes[0].medium.albedo=[1,2,3]"],
         "s.json: shapes[0].medium.albedo: value [1,2,3] is not allowed"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", "spp"], "expected PATH=VALUE"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", "camera.lens.f=1"],
         "camera.lens: unknown key 'lens'"),  # made on the way, then checked
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", " =3"],
         "--set: expected PATH=VALUE, e.g. shapes[0].medium.sigma_t=1000, got ' =3'"),
        # a number JSON cannot hold is an error, not the string "1e400"
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--set", "camera.width=1e400"],
         "--set camera.width: malformed JSON: number overflow parsing '1e400'"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--integrator", "pt", "--step-nee", "event"],
         "step_nee 'event' is an option of integrator 'st' (the integrator is 'pt')"),
        # the scene's integrator is pt: models and threshold given would be ignored
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--models", "{tmp}"],
         "s.json: models is an option of integrator 'st' (the integrator is 'pt')"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--sphere-threshold", "2"],
         "s.json: sphere_threshold is an option of integrator 'st' (the integrator is 'pt')"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--width", "0"], "--width: must be 1 to 16384"),
        (["render", "{scene}", "-o", "{tmp}/x.exr", "--height", "16385"],
         "--height: must be 1 to 16384, got 16385"),
    ],
)
def test_cli_errors_are_clear(tmp_path, small_scene, args, expected):
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    args = [a.format(scene=tmp_path / "s.json", tmp=tmp_path) for a in args]
    r = run_cli(*args)
    assert r.returncode != 0
    assert expected in r.stderr, r.stderr
    assert "Traceback" not in r.stderr



@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_outputs_that_would_lose_the_render_or_an_input_are_refused_before_it(tmp_path, small_scene,
                                                                             cli):
    """An output that is a directory, or lies where no file can be made, was found only once
    the render had finished (its image lost); one naming a file the scene reads (its
    environment map) overwrote it. All are refused before the render. An output through a
    symbolic link replaces the link's target and keeps the link."""
    sky = tmp_path / "sky.exr"
    shutil.copy(os.path.join(REPO, "scenes", "sky.exr"), sky)
    small_scene["lights"] = [light for light in small_scene["lights"]
                             if light["type"] != "environment"]
    small_scene["lights"].append({"type": "environment", "map": "sky.exr"})
    small_scene["render"]["spp"] = 1 << 16  # a render that is never reached
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    (tmp_path / "d.exr").mkdir()
    before = sky.read_bytes()
    cmd = ["render"] if cli == "python" else []
    run = (lambda *a: run_cli(*cmd, *a)) if cli == "python" else \
        (lambda *a: subprocess.run([_cpp_cli(), *map(str, a)], capture_output=True, text=True,
                                   timeout=120))
    for out, expected in ((tmp_path / "d.exr", "d.exr: is a directory"),
                          ("/proc/sss.exr", "/proc/sss.exr: cannot write in '/proc': "),
                          (sky / "x.exr", "output directory '" + str(sky) + "' is a file, not a directory"),
                          (sky, f"sky.exr: is a file the scene reads ('{sky}')")):
        r = run(tmp_path / "s.json", "-o", out)
        assert r.returncode == 1 and expected in r.stderr, r.stderr
    # an AOV file beside a .png: sky_depth.exr is the scene's map too
    sky_depth = tmp_path / "sky_depth.exr"
    sky.rename(sky_depth)
    small_scene["lights"][-1]["map"] = "sky_depth.exr"
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run(tmp_path / "s.json", "-o", tmp_path / "sky.png", "--aovs")
    assert r.returncode == 1 and "sky_depth.exr: is a file the scene reads" in r.stderr, r.stderr
    assert sky_depth.read_bytes() == before and not (tmp_path / "sky.png").exists()
    # A name past what the directory takes (255 bytes on most file systems) was found when
    # the image moved into place (a review); beside a .png the AOV files' names count too
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    for out, aovs in ((f"{'a' * (name_max - 3)}.exr", []), (f"{'b' * (name_max - 7)}.png", ["--aovs"])):
        r = run(tmp_path / "s.json", "-o", tmp_path / out, *aovs)
        assert r.returncode == 1 and f"bytes long (allowed: at most {name_max}" in r.stderr, r.stderr
        assert out not in os.listdir(tmp_path)

    small_scene["render"]["spp"] = 1
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    (tmp_path / "link.exr").symlink_to("target.exr")
    (tmp_path / "target.exr").write_bytes(b"old")
    r = run(tmp_path / "s.json", "-o", tmp_path / "link.exr")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "link.exr").is_symlink()
    assert sssphere.read_image(tmp_path / "target.exr").shape == (16, 24, 3)

def _default_signals():
    # A shell that starts a job in the background without job control (`cmd &` in a
    # script, as a CI runner may) makes it ignore SIGINT, and an ignored SIGINT is
    # inherited: Python would then never see the test's Ctrl-C. The child gets the default.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt_after_start(cmd, tmp_path, sig=signal.SIGINT, after=1.0):
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_signals)
    try:
        # The progress bar's first output says the render has started (after the scene
        # build, which takes longer on a loaded machine); then a few passes.
        first = proc.stderr.read(1)
        time.sleep(after)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:  # the signal did not stop it: do not leave it running
            proc.kill()
            proc.communicate()
    return proc.returncode, first + err


@pytest.fixture
def slow_scene(tmp_path, small_scene):
    small_scene["shapes"][0]["medium"]["sigma_t"] = 100
    small_scene["shapes"][0]["medium"]["albedo"] = 0.999
    small_scene["render"]["spp"] = 1 << 16
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(small_scene))
    return path


def test_ctrl_c_writes_partial_image_python_cli(tmp_path, slow_scene):
    out = tmp_path / "partial.exr"
    code, err = _interrupt_after_start(
        [sys.executable, "-m", "sssphere.cli", "render", str(slow_scene), "-o", str(out)], tmp_path)
    assert code == 130, err
    assert "interrupted: wrote the partial image" in err
    img = sssphere.read_image(out)
    assert np.all(np.isfinite(img)) and img.max() > 0



def test_an_interrupted_turntable_says_which_frame_is_partial(tmp_path, slow_scene):
    """The frame a stop cuts short is kept (it has whole passes) and said to be partial,
    with its samples: it used to be listed as if it were like the others."""
    code, err = _interrupt_after_start(
        [sys.executable, "-m", "sssphere.cli", "render", str(slow_scene), "-o",
         str(tmp_path / "f%03d.exr"), "--turntable", "3"], tmp_path)
    assert code == 130, err
    m = re.search(r"interrupted: wrote 1 of 3 frames .*f000\.exr .*the last, (.*), is partial: "
                  r"(\d+) spp\)", err)
    assert m and m.group(1) == str(tmp_path / "f000.exr"), err
    assert 0 < int(m.group(2)) < 1 << 16
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f000.exr", "slow.json"]


@pytest.mark.parametrize("cli, sig, code", [("python", signal.SIGINT, 130), ("cpp", signal.SIGTERM, 143)])
def test_interrupted_before_the_first_pass_writes_nothing_and_says_so(tmp_path, slow_scene, cli, sig, code):
    """A render stopped before its first pass (1 spp of every pixel) has finished has no
    image to keep: it writes nothing, rather than an all-black image, and says so. Here
    the first pass is a million paths of ~1000 events, tens of seconds."""
    scene = json.loads(slow_scene.read_text())
    scene["camera"]["width"] = scene["camera"]["height"] = 1024
    slow_scene.write_text(json.dumps(scene))
    out = tmp_path / "never.exr"
    cmd = [sys.executable, "-m", "sssphere.cli", "render"] if cli == "python" else [_cpp_cli()]
    start = time.monotonic()
    got, err = _interrupt_after_start([*cmd, str(slow_scene), "-o", str(out)], tmp_path, sig)
    assert got == code, err
    assert time.monotonic() - start < 60, err  # stopped mid-pass, not at its end
    assert f"interrupted before the first pass finished: wrote nothing to {out}" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.json"]


@pytest.fixture
def cli_in_process():
    """sssphere.cli.main run in this process, its SIGTERM and SIGHUP handlers undone
    afterwards."""
    from sssphere import cli

    previous = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)}
    yield cli.main
    for s, handler in previous.items():
        signal.signal(s, handler)


def test_ctrl_c_once_the_render_has_finished_still_writes_it(tmp_path, small_scene, monkeypatch,
                                                             capsys, cli_in_process):
    """Ctrl-C while the finished render's AOVs are made (or it is denoised, written, a Ray
    cluster shut down) delays the exit: the whole render is written, and the status says
    it was interrupted. It used to reach the top level and write nothing."""
    from sssphere import rendering

    expected = sssphere.render(sssphere.load_scene(small_scene), spp=4, seed=5)
    real_with_aovs = rendering.with_aovs

    def with_aovs_under_ctrl_c(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # its handler runs at the next bytecode
        return real_with_aovs(*args, **kwargs)

    monkeypatch.setattr(rendering, "with_aovs", with_aovs_under_ctrl_c)
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    out = tmp_path / "after.exr"
    status = cli_in_process(["render", str(tmp_path / "s.json"), "-o", str(out), "--spp", "4",
                             "--seed", "5", "--aovs", "--quiet"])
    err = capsys.readouterr().err
    assert status == 130, err
    assert "interrupted once the render had finished: wrote" in err, err
    np.testing.assert_array_equal(sssphere.read_layers(out)[""], expected)


def test_a_second_ctrl_c_while_the_partial_image_is_written_does_not_lose_it(
        tmp_path, slow_scene, monkeypatch, capfd, cli_in_process):
    """The first Ctrl-C stops the render; a second one, while its AOVs are made and it is
    written, is only noted (a third would end the process)."""
    from sssphere import rendering

    real_render, real_with_aovs = rendering._render, rendering.with_aovs
    calls = []

    def render_under_ctrl_c(scene, progress, *args, **kwargs):
        def progress_under_ctrl_c(fraction):
            calls.append(fraction)
            if len(calls) == 3:  # the render is under way: Ctrl-C
                os.kill(os.getpid(), signal.SIGINT)
            return progress(fraction)
        return real_render(scene, progress_under_ctrl_c, *args, **kwargs)

    def with_aovs_under_ctrl_c(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        return real_with_aovs(*args, **kwargs)

    monkeypatch.setattr(rendering, "_render", render_under_ctrl_c)
    monkeypatch.setattr(rendering, "with_aovs", with_aovs_under_ctrl_c)
    out = tmp_path / "partial.exr"
    status = cli_in_process(["render", str(slow_scene), "-o", str(out), "--aovs", "--quiet"])
    err = capfd.readouterr().err
    assert status == 130, err
    assert "interrupted again: still writing what was rendered" in err, err
    spp = int(re.search(r"interrupted: wrote the partial image .* (\d+) spp", err).group(1))
    assert 0 < spp < 1 << 16, err
    layers = sssphere.read_layers(out)
    assert np.all(np.isfinite(layers[""])) and layers[""].max() > 0 and "albedo" in layers


@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_a_signal_ignored_from_the_start_stays_ignored(tmp_path, slow_scene, cli):
    """A job started in the background without job control ignores SIGINT: a Ctrl-C meant
    for the foreground must not stop it. The render runs to its time limit."""
    cmd = ([sys.executable, "-m", "sssphere.cli", "render"] if cli == "python" else [_cpp_cli()])
    proc = subprocess.Popen([*cmd, str(slow_scene), "-o", str(tmp_path / "bg.exr"),
                             "--time-limit", "3"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        first = proc.stderr.read(1)  # the progress bar: the render has started
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, first + err
    assert "time limit reached" in err, err

def _read_pty(fd: int, until: bytes | None, timeout: float) -> bytes:
    """What the child writes to the terminal `fd` until `until` appears (None: until it
    closes the terminal) or `timeout` seconds pass."""
    out, deadline = b"", time.monotonic() + timeout
    while (until is None or until not in out) and time.monotonic() < deadline:
        if select.select([fd], [], [], 0.1)[0]:
            try:
                chunk = os.read(fd, 4096)
            except OSError:  # EIO: the child has closed the terminal
                break
            if not chunk:
                break
            out += chunk
    return out


def _slow_loading(scene: dict) -> dict:
    scene["render"]["grid_resolution"] = 384  # a build of 5-8 s on 2 cores
    return scene


_slow_load_seconds: list[float] = []


@pytest.fixture
def slow_load_seconds(small_scene) -> float:
    """How long _slow_loading's scene takes to load here, uninterrupted (measured once)."""
    if not _slow_load_seconds:
        start = time.monotonic()
        sssphere.load_scene(_slow_loading(copy.deepcopy(small_scene)))
        _slow_load_seconds.append(time.monotonic() - start)
    return _slow_load_seconds[0]


@pytest.mark.parametrize("cli", ["python", "cpp"])
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_ctrl_c_while_the_scene_loads_writes_nothing_and_says_so(tmp_path, small_scene, sig, code, cli,
                                                                 slow_load_seconds):
    """Ctrl-C or SIGTERM while the scene is still being built stops either command line (the
    grid build at its next row of nodes), with one line and the exit status of an
    interrupted render (not a KeyboardInterrupt traceback, nor death by the signal). On a
    terminal it says when it starts loading: the signal is sent half a second later, during
    a build of seconds (a signal before the build gets the same answer), and the command
    ends well before the build would have (half its time, measured in this run)."""
    _slow_loading(small_scene)
    scene, out = tmp_path / "s.json", tmp_path / "x.exr"
    scene.write_text(json.dumps(small_scene))
    terminal, child_end = pty.openpty()
    command = ([sys.executable, "-m", "sssphere.cli", "render"] if cli == "python"
               else [_cpp_cli()])
    proc = subprocess.Popen([*command, str(scene), "-o", str(out)],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=child_end,
                            preexec_fn=_default_signals)
    os.close(child_end)
    try:
        err = _read_pty(terminal, b"loading", timeout=120)
        assert b"loading" in err, err
        time.sleep(0.5)  # past the few ms of Python before the build
        proc.send_signal(sig)
        sent = time.monotonic()
        err += _read_pty(terminal, None, timeout=120)
        proc.wait(timeout=120)
        after_signal = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(terminal)
    err = err.decode(errors="replace")
    assert proc.returncode == code, err
    assert "Traceback" not in err, err
    assert f"interrupted while loading the scene: wrote nothing to {out}" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]
    # half of what was left of the build when the signal came
    assert after_signal < 0.5 * (slow_load_seconds - 0.5), (after_signal, slow_load_seconds)


def test_a_second_signal_ends_a_long_load_of_the_cpp_cli_at_once(tmp_path, small_scene):
    """A first signal during the parts of the load that do not poll for it (reading and
    checking the meshes, the BVH, the grid's search trees) is kept, to be said once they
    return; the next ends the process then and there, as nothing has been written yet."""
    # 1.3 million triangles: about a second and a half before the grid's first slab
    small_scene["shapes"][0]["sphere"]["subdivisions"] = 7
    small_scene["render"]["grid_resolution"] = 16
    scene, out = tmp_path / "s.json", tmp_path / "x.exr"
    scene.write_text(json.dumps(small_scene))
    terminal, child_end = pty.openpty()
    proc = subprocess.Popen([_cpp_cli(), str(scene), "-o", str(out)], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=child_end, preexec_fn=_default_signals)
    os.close(child_end)
    try:
        assert b"loading" in _read_pty(terminal, b"loading", timeout=120)
        time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        time.sleep(0.1)
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(terminal)
    assert proc.returncode == -signal.SIGTERM  # the default action, not 143 after the build
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def _cpp_cli() -> str:
    # The one installed beside this interpreter (install.sh's environment), else the dev build
    exe = os.path.join(os.path.dirname(sys.executable), "sssphere-render")
    if not os.path.exists(exe):
        exe = shutil.which("sssphere-render") or os.path.join(REPO, "build", "dev", "cpp", "sssphere-render")
    if not os.path.exists(exe):
        pytest.fail("the C++ renderer sssphere-render was not built")
    return exe


def test_both_command_lines_default_to_the_same_models():
    """sssphere-render's default models are the Python package's (its --help names them).
    In an editable install the package uses the repository's models/ while sssphere-render
    took a copy installed into site-packages, which `sssphere train -o models/` left stale."""
    from sssphere.model import DEFAULT_MODELS

    out = subprocess.run([_cpp_cli(), "--help"], capture_output=True, text=True).stdout
    default = re.search(r"--models DIR=(\S+)", out)
    assert default, out
    assert Path(default.group(1)).resolve() == DEFAULT_MODELS.resolve()


def assert_reports_step_cost(stderr: str):
    """The summary line gives the steps per path and the time one took."""
    m = re.search(r"\+ ([0-9.]+) sphere steps \(([0-9]+) ns each\) per path", stderr)
    assert m, stderr
    assert float(m.group(1)) > 0 and int(m.group(2)) > 0, stderr


def test_step_nee_option_of_both_clis(tmp_path, small_scene):
    """--step-nee reaches the renderer: the same image as render(step_nee=...) from Python,
    and a clear error for a value that is not allowed."""
    small_scene["shapes"][0]["medium"].update(sigma_t=50, albedo=0.95)
    small_scene["render"].update(integrator="st", spp=2)
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    expected = sssphere.render(sssphere.load_scene(small_scene), step_nee="event")
    r = run_cli("render", tmp_path / "s.json", "-o", tmp_path / "py.exr", "--quiet", "--step-nee", "event")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "py.exr"), expected)
    assert_reports_step_cost(r.stderr)
    exe = _cpp_cli()
    r = subprocess.run([exe, str(tmp_path / "s.json"), "-o", str(tmp_path / "cpp.exr"), "--quiet",
                        "--step-nee", "event"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(sssphere.read_image(tmp_path / "cpp.exr"), expected)
    assert_reports_step_cost(r.stderr)
    r = subprocess.run([exe, str(tmp_path / "s.json"), "-o", str(tmp_path / "cpp.exr"), "--step-nee", "paper"],
                       capture_output=True, text=True)
    assert r.returncode != 0
    assert "--step-nee 'paper' is not allowed (allowed: 'hits', 'event')" in r.stderr, r.stderr


def test_ctrl_c_writes_partial_image_cpp_cli(tmp_path, slow_scene):
    exe = _cpp_cli()
    out = tmp_path / "partial.png"
    code, err = _interrupt_after_start([exe, str(slow_scene), "-o", str(out)], tmp_path)
    assert code == 130, err
    assert "interrupted: wrote the partial image" in err
    assert sssphere.read_image(out).shape == (16, 24, 3)


@pytest.mark.skipif(not _core.gpu_status()[0], reason="no Vulkan device")
def test_backend_option_renders_on_the_gpu(tmp_path, small_scene):
    # The CLI's image is the Python API's on the same backend, with NEE and without, for
    # both integrators (st's steps keep their clearance from the point light).
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    for integrator in ("pt", "st"):
        for flags, nee in ((["--no-nee"], False), ([], True)):
            r = run_cli("render", tmp_path / "s.json", "-o", tmp_path / "gpu.exr", "--spp", 2,
                        "--backend", "vulkan", "--integrator", integrator, "--quiet", *flags)
            assert r.returncode == 0, r.stderr
            assert f"on {_core.gpu_status()[1]};" in r.stderr, r.stderr  # names the device
            expected = sssphere.render(sssphere.load_scene(small_scene), integrator=integrator,
                                       spp=2, nee=nee, backend="vulkan")
            np.testing.assert_array_equal(sssphere.read_image(tmp_path / "gpu.exr"), expected)


def test_both_command_lines_print_the_same_summary(tmp_path, small_scene):
    """The summary lines differed in form ("wrote X: 0.2 s, 2 spp, ..." against "wrote X
    (24x16, 2 spp; ...)"), and sssphere-render did not say it wrote AOV files beside a .png.
    They are the same, word for word, once the numbers are left out."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    lines = []
    for name, cmd in (("python", [sys.executable, "-m", "sssphere.cli", "render"]),
                      ("cpp", [_cpp_cli()])):
        out = tmp_path / f"{name}.png"
        r = subprocess.run([*cmd, str(tmp_path / "s.json"), "-o", str(out), "--spp", "2",
                            "--aovs", "--quiet", "--integrator", "st"],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        line = r.stderr.strip().splitlines()[-1].replace(str(tmp_path), "DIR").replace(name, "X")
        lines.append(re.sub(r"[0-9]+(\.[0-9]+)?", "N", line))
    assert lines[0] == lines[1], lines
    assert "AOV files beside it (X_variance.exr, ...)" in lines[0], lines[0]


def _long_options(help_text: str) -> set[str]:
    return set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", help_text)) - {"--help"}


def test_both_command_lines_take_the_same_options():
    """`sssphere render` and `sssphere-render` are built from one table of render options
    (render/options.h); their --help lists the same long options, every one of the table's."""
    py = run_cli("render", "--help")
    cpp = subprocess.run([_cpp_cli(), "--help"], capture_output=True, text=True)
    assert py.returncode == 0 and cpp.returncode == 0, (py.stderr, cpp.stderr)
    ours, theirs = _long_options(py.stdout), _long_options(cpp.stdout)
    # Python's alone (docs/options.md): denoising runs pyoidn, --turntable is built on
    # render_frames and the editable scene, --ray on Ray's Python API.
    python_only = {"--denoise", "--turntable", "--ray"}
    assert ours - python_only == theirs, (ours ^ theirs)
    for spec in _core.render_option_specs():
        if spec["command_line"]:
            flag = spec["name"].replace("_", "-")
            assert (f"--no-{flag}" if spec["kind"] == "flag" else f"--{flag}") in theirs, spec["name"]


def _render_with_both(tmp_path: Path, args: list[str]) -> list:
    """`sssphere render` and `sssphere-render` of tmp_path/s.json to x.exr with `args`."""
    scene, out = str(tmp_path / "s.json"), str(tmp_path / "x.exr")
    return [run_cli("render", scene, "-o", out, *args),
            subprocess.run([_cpp_cli(), scene, "-o", out, *args], capture_output=True, text=True)]


def test_both_command_lines_reject_a_bad_option_value_alike(tmp_path, small_scene):
    """A value out of range is a usage error naming the flag, status 2, as --width 0 is
    (it was status 1 and named the option as the scene's render block does); so is a --set
    without PATH=VALUE (status 1 until a review)."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    for args, message in ((["--spp", "0"], "--spp must be an integer >= 1"),
                          (["--spp", "x"], "--spp: expected an integer >= 1"),
                          (["--integrator", "mc"],
                           "--integrator 'mc' is not allowed (allowed: 'pt', 'st')"),
                          (["--width", "0"], "--width: must be 1 to 16384, got 0"),
                          # sssphere-render said "Value 16.5 not in range 1 to 16384"
                          (["--width", "16.5"], "--width: expected an integer, got '16.5'"),
                          (["--set", "nokey"], "--set: expected PATH=VALUE"),
                          (["--set", "=1"], "--set: expected PATH=VALUE")):
        for r in _render_with_both(tmp_path, args):
            assert r.returncode == 2 and message in r.stderr, (args, r.stderr)
    # The same values in the scene's render block are the scene's errors, status 1
    small_scene["render"]["spp"] = 0
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    for r in _render_with_both(tmp_path, []):
        assert r.returncode == 1 and "render.spp" in r.stderr, r.stderr


def test_options_of_st_given_with_pt_are_refused_by_both(tmp_path, small_scene):
    """--models and --sphere-threshold with the scene's pt were accepted and ignored by both
    command lines (a review): refused as --step-nee event with pt is, before any progress bar.
    With --integrator st they are taken."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    models = os.path.join(REPO, "models")
    for args, name in ((["--models", models], "models"), (["--sphere-threshold", "2"], "sphere_threshold")):
        for r in _render_with_both(tmp_path, args):
            assert r.returncode == 1, r.stderr
            assert f"{name} is an option of integrator 'st' (the integrator is 'pt')" in r.stderr
            assert "%" not in r.stderr, r.stderr  # no progress bar was drawn
        for r in _render_with_both(tmp_path, [*args, "--integrator", "st", "--spp", "1"]):
            assert r.returncode == 0, r.stderr


def test_an_option_given_twice_takes_its_last_value_in_both(tmp_path, small_scene):
    """`--spp 2 --spp 3`: 3 samples in both command lines (argparse takes the last value;
    sssphere-render refused it with CLI11's "At Most 1 required but received 2", a review).
    The summary line says how many samples each pixel has."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    for r in _render_with_both(tmp_path, ["--spp", "2", "--spp", "3"]):
        assert r.returncode == 0, r.stderr
        assert re.search(r"\b3 spp\b", r.stderr), r.stderr


def test_a_bad_option_value_is_refused_before_the_scene_is_read(tmp_path, small_scene):
    """Each option's value is checked before the scene is read (building it can take
    seconds): with a scene that cannot be read, the option is what the error names."""
    del small_scene["shapes"][0]["sphere"]
    small_scene["shapes"][0]["mesh"] = str(tmp_path / "missing.obj")
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    for args, message in ((["--spp", "0"], "--spp must be an integer >= 1"),
                          (["--threads", "5000"], "--threads must be an integer from 0 to 4096"),
                          (["--time-limit", "-1"], "--time-limit must be a number from 0 to 1e9"),
                          (["--sphere-threshold", "-2"], "--sphere-threshold must be a number >= 0"),
                          (["--backend", "metal"], "--backend 'metal' is not allowed")):
        for r in _render_with_both(tmp_path, args):
            assert r.returncode == 2 and message in r.stderr, (args, r.stderr)
            assert "missing.obj" not in r.stderr, (args, r.stderr)
    with pytest.raises(sssphere.SceneError, match="spp must be an integer >= 1"):
        sssphere.render_full(tmp_path / "s.json", spp=0)


def test_the_options_page_lists_every_option():
    with open(os.path.join(REPO, "docs", "options.md"), encoding="utf-8") as f:
        page = f.read()
    for spec in _core.render_option_specs():
        assert f"| `{spec['name']}` |" in page, spec["name"]


@pytest.mark.parametrize("cli", ["python", "cpp"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_writes_the_partial_image_and_exits_143(tmp_path, slow_scene, cli, sig):
    """SIGTERM (kill, batch schedulers) stops a render as Ctrl-C does, within a second, and
    says so by its exit status 143 (128 + 15). So does SIGHUP (a closed terminal, a dropped
    ssh session: it killed the render and wrote nothing, a review), exit status 129, saying
    nothing: the terminal is gone."""
    out = tmp_path / "partial.exr"
    cmd = ([sys.executable, "-m", "sssphere.cli", "render"] if cli == "python" else [_cpp_cli()])
    start = time.monotonic()
    code, err = _interrupt_after_start([*cmd, str(slow_scene), "-o", str(out)], tmp_path, sig)
    assert code == 128 + sig, err
    assert time.monotonic() - start < 30  # not the 2^16 spp the scene asks for
    assert ("wrote the partial image" in err) == (sig == signal.SIGTERM), err
    img = sssphere.read_image(out)
    assert np.all(np.isfinite(img)) and img.max() > 0


def test_sigterm_keeps_the_walks_datagen_finished(tmp_path):
    out = tmp_path / "walks.npz"
    code, err = _interrupt_after_start([sys.executable, "-m", "sssphere.cli", "datagen", "--samples",
                                        "2000000", "-o", str(out)], tmp_path, signal.SIGTERM, after=5.0)
    assert code == 143, err
    assert "interrupted: wrote the walks finished so far" in err
    with np.load(out) as data:
        assert 0 < len(data["N"]) < 2_000_000 and len(data["N"]) % 10_000 == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walks.npz"]


@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_time_limit_option_stops_the_render_and_reports_the_spp(tmp_path, slow_scene, cli):
    """--time-limit S ends a render of the scene's 2^16 spp after S seconds of rendering,
    writes an image of the whole passes done, says how many spp that is and exits 0."""
    out = tmp_path / "timed.exr"
    cmd = ([sys.executable, "-m", "sssphere.cli", "render"] if cli == "python" else [_cpp_cli()])
    r = subprocess.run([*cmd, str(slow_scene), "-o", str(out), "--time-limit", "0.5", "--quiet",
                        "--seed", "4"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "time limit reached" in r.stderr, r.stderr
    spp = int(re.search(r"(\d+) spp", r.stderr).group(1))
    assert 1 <= spp < 1 << 16
    expected = sssphere.render(sssphere.load_scene(slow_scene), spp=spp, seed=4)
    np.testing.assert_allclose(sssphere.read_image(out), expected, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_set_and_image_size_change_the_scene(tmp_path, small_scene, cli):
    """--set PATH=VALUE (JSON, or a bare string) and --width (the height follows the aspect
    ratio, 24x16 -> 36x24) render what the edited scene renders, bit for bit, in both command
    lines (one implementation: render/scene.h, edit_scene_json). The scene has no `render`
    block: --set render.integrator makes it (it was "render is not in the scene", though the
    docs gave that very example)."""
    del small_scene["render"]
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    args = [tmp_path / "s.json", "-o", tmp_path / "x.exr", "--spp", 2, "--quiet",
            "--set", "shapes[0].medium.sigma_t=[3, 4, 5]", "--set", "render.integrator=pt",
            "--set", "shapes[0].medium.scale=2", "--width", 36]
    r = (run_cli("render", *args) if cli == "python"
         else subprocess.run([_cpp_cli(), *map(str, args)], capture_output=True, text=True))
    assert r.returncode == 0, r.stderr
    edited = json.loads(json.dumps(small_scene))
    edited["shapes"][0]["medium"].update(sigma_t=[3, 4, 5], scale=2)
    edited.setdefault("render", {})["integrator"] = "pt"
    edited["camera"].update(width=36, height=24)
    expected = sssphere.render(sssphere.load_scene(edited), spp=2)
    img = sssphere.read_image(tmp_path / "x.exr")
    assert img.shape == (24, 36, 3)
    np.testing.assert_array_equal(img, expected)


@pytest.mark.parametrize("cli", ["python", "cpp"])
@pytest.mark.parametrize("field", ["camera.width", "camera.height", "camera", " camera.width "])
def test_set_of_the_image_size_with_width_is_refused(tmp_path, small_scene, cli, field):
    """--set camera.width=-5 --width 16 rendered at width 16 without a word: --width replaced
    the --set value before anything read it. Both naming the size is refused."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    value = json.dumps(small_scene["camera"]) if field == "camera" else "-5"
    args = [tmp_path / "s.json", "-o", tmp_path / "x.exr", "--spp", 1, "--quiet",
            "--set", f"{field}={value}", "--width", 16]
    r = (run_cli("render", *args) if cli == "python"
         else subprocess.run([_cpp_cli(), *map(str, args)], capture_output=True, text=True))
    assert r.returncode != 0 and "Traceback" not in r.stderr, r.stderr
    assert f"--set {field.strip()} and --width/--height both give the image size" in r.stderr, r.stderr
    assert not (tmp_path / "x.exr").exists()


@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_set_refuses_a_key_given_twice_as_the_scene_file_does(tmp_path, small_scene, cli):
    """A --set value with a key twice rendered with the last one (an outside sweep); in a scene
    file it is refused. Both are refused now, naming the key."""
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    args = [tmp_path / "s.json", "-o", tmp_path / "x.exr", "--spp", 1, "--quiet", "--set",
            'shapes[0].medium={"sigma_t": 1, "albedo": 1, "sigma_t": 2}']
    r = (run_cli("render", *args) if cli == "python"
         else subprocess.run([_cpp_cli(), *map(str, args)], capture_output=True, text=True))
    assert r.returncode != 0 and "Traceback" not in r.stderr, r.stderr
    assert ("--set shapes[0].medium: sigma_t: key 'sigma_t' appears twice in one object "
            "(allowed: once)") in r.stderr, r.stderr
    assert not (tmp_path / "x.exr").exists()


def test_info_json_is_json_for_a_medium_without_extinction(tmp_path, small_scene):
    """A medium of sigma_t 0 (allowed) has an infinite mean free path: `info --json` wrote it
    as `Infinity`, which is not JSON. It is null now, and the text says inf."""
    small_scene["shapes"][0]["medium"] = {"sigma_t": [0, 1, 2], "albedo": 0.9}
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("info", tmp_path / "s.json", "--json")
    assert r.returncode == 0 and "Warning" not in r.stderr, r.stderr

    def no_constants(name):
        raise AssertionError(f"not JSON: {name}")

    info = json.loads(r.stdout, parse_constant=no_constants)
    assert json.dumps(info).count("null") >= 1
    r = run_cli("info", tmp_path / "s.json")
    assert r.returncode == 0 and "mean free path [inf, 1, 0.5]" in r.stdout, r.stdout


def test_unwritable_export_paths_are_one_line_errors(tmp_path, small_scene):
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    (tmp_path / "d.xml").mkdir()
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "d.xml")
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith("sssphere: error:") and "d.xml" in r.stderr, r.stderr
    r = run_cli("export-mitsuba", tmp_path / "s.json", "/proc/m.xml")  # was a raw OSError
    assert r.returncode == 1 and "/proc/m.xml: cannot make the meshes' directory" in r.stderr
    # Mitsuba's seeds are 32-bit: a larger one wrote a scene Mitsuba then refused (a review)
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "m.xml", "--seed", str(2**32))
    assert r.returncode == 2 and "--seed: must be 0 to 4294967295" in r.stderr, r.stderr
    assert not (tmp_path / "m.xml").exists()


def test_export_mitsuba_says_scene_warnings_as_render_does(tmp_path, small_scene):
    """export-mitsuba printed a scene's warning as Python's raw warning (source path and
    code line; an outside sweep); render and info print `sssphere: warning: ...`."""
    small_scene["lights"][0]["position"] = [1e9, 2, 0]
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "m.xml")
    assert r.returncode == 0, r.stderr
    assert "sssphere: warning: " in r.stderr and "lights[0]" in r.stderr, r.stderr
    assert "SceneWarning" not in r.stderr and "mitsuba.py" not in r.stderr, r.stderr


def test_export_mitsuba_says_it_leaves_max_bounces_out(tmp_path, small_scene):
    """A scene rendered with max_bounces (single scattering) exported as full multiple
    scattering without a word (a review); Mitsuba's max_depth counts other things."""
    small_scene.setdefault("render", {})["max_bounces"] = 1
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "m.xml")
    assert r.returncode == 0, r.stderr
    assert "sssphere: warning: " in r.stderr and "max_bounces 1 is not exported" in r.stderr, \
        r.stderr


def test_export_mitsuba_warns_of_a_sigma_t_channel_of_zero(tmp_path, small_scene):
    """Mitsuba 3 renders a medium with sigma_t [0, 2, 6] wrong (volpath NaN, volpathmis
    G and B at a third of ours, which match grey media of sigma_t 2 and 6; an outside
    comparison): the export says so."""
    small_scene["shapes"][0]["medium"]["sigma_t"] = [0, 2, 6]
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "m.xml")
    assert r.returncode == 0, r.stderr
    assert "sssphere: warning: " in r.stderr and "has a channel of 0" in r.stderr, r.stderr
    small_scene["shapes"][0]["medium"]["sigma_t"] = [1e-3, 2, 6]
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    r = run_cli("export-mitsuba", tmp_path / "s.json", tmp_path / "m.xml")
    assert r.returncode == 0 and "channel of 0" not in r.stderr, r.stderr


def test_a_reader_that_leaves_early_ends_the_command_quietly():
    """`sssphere presets | head -1`: when the reader of stdout has gone, the command ends as
    one killed by SIGPIPE (status 141) without a message (it said "error: Broken pipe")."""
    with subprocess.Popen([sys.executable, "-m", "sssphere.cli", "presets"],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        proc.stdout.close()  # before the child has imported anything, let alone written
        err = proc.stderr.read()
        assert proc.wait(timeout=120) == 128 + signal.SIGPIPE, err
    assert err == ""


def test_ctrl_c_while_the_command_loads_is_one_line():
    """Ctrl-C during the imports of the command (NumPy, the C++ module: a second or more)
    printed a traceback of the import; the `sssphere` script's entry point ends as a later
    interrupt does. The interrupt arrives here as an import that raises it."""
    stop = ("import sys\n"
            "class Stop:\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name == 'numpy':\n"
            "            raise KeyboardInterrupt\n"
            "sys.meta_path.insert(0, Stop())\n"
            "from sssphere import _entry\n"
            "sys.exit(_entry.main())\n")
    r = subprocess.run([sys.executable, "-c", stop, "presets"], capture_output=True, text=True,
                       timeout=120)
    assert (r.returncode, r.stderr) == (130, "sssphere: interrupted\n")
    # SIGTERM in the same place: it was death by the signal, without a word
    term = stop.replace("raise KeyboardInterrupt",
                        "import os, signal; os.kill(os.getpid(), signal.SIGTERM)")
    r = subprocess.run([sys.executable, "-c", term, "presets"], capture_output=True, text=True,
                       timeout=120, preexec_fn=_default_signals)
    assert (r.returncode, r.stderr) == (143, "sssphere: interrupted\n")
    script = Path(sys.executable).parent / "sssphere"  # the installed command uses it
    assert "sssphere._entry" in script.read_text()


def test_a_broken_pipe_other_than_stdout_is_an_error(monkeypatch, capsys):
    """Only a closed stdout ends quietly: a broken pipe elsewhere (a cluster connection, a
    FIFO given as the output) is reported as any OSError is."""
    from sssphere import cli

    def broken(args):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(cli, "_cmd_presets", broken)
    assert cli.main(["presets"]) == 1
    assert "sssphere: error: [Errno 32] Broken pipe" in capsys.readouterr().err


def test_a_turntable_holds_one_frame_at_a_time(tmp_path, small_scene, monkeypatch, cli_in_process):
    """`render --turntable` kept every frame's result (image, variance, AOVs) until the last
    was done, though each is written as it finishes: memory grew by a frame each time (tens of
    GB for 360 frames at 1080p). Now a frame is let go once written."""
    import gc
    import weakref

    from sssphere import rendering

    real, frames, most_alive = rendering.with_aovs, [], []

    def counted(*args, **kwargs):
        gc.collect()
        most_alive.append(sum(ref() is not None for ref in frames))
        result = real(*args, **kwargs)
        frames.append(weakref.ref(result))
        return result

    monkeypatch.setattr(rendering, "with_aovs", counted)
    small_scene["render"]["spp"] = 1
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    status = cli_in_process(["render", str(tmp_path / "s.json"), "-o", str(tmp_path / "f%02d.exr"),
                             "--turntable", "5", "--aovs", "--quiet"])
    assert status == 0
    assert len(frames) == 5 and sorted(p.name for p in tmp_path.glob("f*.exr")) == [
        f"f{k:02d}.exr" for k in range(5)]
    assert max(most_alive) == 0, most_alive


def test_a_turntable_pattern_may_hold_a_percent_sign(tmp_path, small_scene, cli_in_process,
                                                    capsys):
    """%% in the frame pattern is a literal %, as in printf: 'f100%%_%d.png' was refused as
    holding more than one conversion. A pattern with two frame numbers still is."""
    small_scene["render"]["spp"] = 1
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    status = cli_in_process(["render", str(tmp_path / "s.json"), "-o",
                             str(tmp_path / "f100%%_%d.png"), "--turntable", "2", "--quiet"])
    assert status == 0
    assert sorted(p.name for p in tmp_path.glob("f*.png")) == ["f100%_0.png", "f100%_1.png"]
    status = cli_in_process(["render", str(tmp_path / "s.json"), "-o",
                             str(tmp_path / "g%d_%d.png"), "--turntable", "2", "--quiet"])
    assert status == 1 and "one %d or %03d (and %% for a %)" in capsys.readouterr().err


@pytest.mark.parametrize("cli", ["python", "cpp"])
def test_st_on_a_medium_the_models_were_not_trained_for_says_so_and_renders(tmp_path, small_scene,
                                                                            models_with, cli):
    """Both command lines say, once and before the render starts (its progress bar), that
    such a medium takes no sphere steps (it renders as with pt); the Python one as its
    other warnings, not in Python's raw format."""
    models = models_with(g=[-0.2, 0.2])  # the scene's g is 0.3
    small_scene["shapes"][0]["medium"]["sigma_t"] = [100, 100, 100]  # deep enough for steps
    (tmp_path / "s.json").write_text(json.dumps(small_scene))
    args = [tmp_path / "s.json", "-o", tmp_path / "x.exr", "--integrator", "st", "--models",
            models, "--spp", 2]
    r = (run_cli("render", *args) if cli == "python" else
         subprocess.run([_cpp_cli(), *map(str, args)], capture_output=True, text=True,
                        timeout=300))
    assert r.returncode == 0, r.stderr
    prefix = "sssphere: warning: " if cli == "python" else "sssphere-render: warning: "
    said = [line for line in r.stderr.splitlines() if "takes no sphere steps" in line]
    assert len(said) == 1 and said[0].startswith(prefix), r.stderr
    assert "shapes[0] ('ball')" in said[0] and "g = 0.3 is outside the training range" in said[0]
    assert "SceneWarning" not in r.stderr, r.stderr
    assert r.stderr.index(said[0]) < r.stderr.index("100.0%"), r.stderr  # both bars say it


def test_calibrate_tilt_writes_a_table_the_renderer_reads(tmp_path, capsys, monkeypatch):
    """`sssphere calibrate-tilt` end to end on a small grid (the real one takes ~25 min): it
    measures the decoders without any tilt already there, writes tilt.json beside them, and
    the C++ loader takes it; bad outputs and directories are told before any work."""
    from sssphere.cli import main
    from sssphere.learn import tilt
    from sssphere.model import DEFAULT_MODELS

    models = tmp_path / "m"
    models.mkdir()
    for name in ("lengthgen.json", "pathgen.json", "eventgen.json", "tilt.json"):
        shutil.copy(DEFAULT_MODELS / name, models / name)
    monkeypatch.setattr(tilt, "SIGMAS", (20.0, 40.0))
    monkeypatch.setattr(tilt, "GS", (0.5, 0.9))
    monkeypatch.setattr(tilt, "MODEL_SAMPLES", 20_000)
    monkeypatch.setattr(tilt, "WALK_MIN", 5_000)
    monkeypatch.setattr(tilt, "WALK_MAX", 5_000)
    assert main(["calibrate-tilt", "--models", str(models), "--quiet"]) == 0, capsys.readouterr().err
    written = json.loads((models / "tilt.json").read_text())
    assert written["sigma"] == [20.0, 40.0] and written["g"] == [0.5, 0.9]
    assert len(written["a"]) == 2 and len(written["a"][0]) == 2
    assert len(written["calibration"]["cells"]) == 4
    # the decoders' own steps were measured, not the shipped tilt's
    plain = tilt.moments(sssphere.ScatteringModel.load(models, tilt=False).sample(
        sigma_t=20.0, g=0.5, albedo=0.9999, n=20_000, seed=11))
    assert written["calibration"]["cells"][0]["model"] == plain
    assert sssphere.ScatteringModel.load(models).tilted

    capsys.readouterr()
    assert main(["calibrate-tilt", "--models", str(tmp_path / "none"), "--quiet"]) == 1
    assert "none: not a directory" in capsys.readouterr().err
    assert main(["calibrate-tilt", "--models", str(models), "-o", str(tmp_path), "--quiet"]) == 1
    assert "is a directory, not a tilt file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["calibrate-tilt", "--models", str(models), "--seed", str(2**64 - 1)])
    assert "the walks take seed + 1" in capsys.readouterr().err
