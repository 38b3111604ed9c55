"""The `sssphere` command line: `sssphere render SCENE.json -o out.exr`, `sssphere datagen`, ..."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import select
import shlex
import signal
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from sssphere._progress import Progress
from sssphere._version import __version__
from sssphere import _core, rendering
from sssphere.rendering import RENDER_OPTIONS
from sssphere.scene import SceneError, SceneWarning, load_scene_with


@contextlib.contextmanager
def _said_warnings():
    """The SceneWarnings (and any other warning) raised inside, each said once, as a
    `sssphere: warning: ...` line when it is raised (above a progress bar: a render's
    warnings about its media come before it starts)."""
    said = set()

    def say(message, category, filename, lineno, file=None, line=None):
        if str(message) not in said:
            said.add(str(message))
            tqdm.write(f"sssphere: warning: {message}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.simplefilter("always", SceneWarning)
        warnings.showwarning = say
        yield


def _checked(convert, ok, requirement: str):
    """An argparse type: convert(text), then ok(value) or an error saying the requirement."""
    what = "an integer" if convert is int else "a number"

    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"must be {requirement}, got {text}")
        return value

    return parse


_positive_int = _checked(int, lambda v: v >= 1, ">= 1")
_non_negative_int = _checked(int, lambda v: v >= 0, ">= 0")
# Mitsuba's sampler takes 32-bit seeds: a larger one wrote a scene Mitsuba refuses
_mitsuba_seed = _checked(int, lambda v: 0 <= v < 2**32, "0 to 4294967295 (Mitsuba's seeds are 32-bit)")
# calibrate-tilt's walks take seed + 1, a 64-bit stream number
_tilt_seed = _checked(int, lambda v: 0 <= v < 2**64 - 1, "0 to 2^64 - 2 (the walks take seed + 1)")
_positive_float = _checked(float, lambda v: 0 < v < float("inf"), "a positive number")
# camera.width and height's range (docs/scene-format.md), checked as sssphere-render does
_image_size = _checked(int, lambda v: 1 <= v <= 16384, "1 to 16384")


def _assignment(text: str) -> str:
    """--set PATH=VALUE: a PATH and an '=' (the value is the scene's to check); without
    them a usage error, status 2, as the C++ command line's."""
    if "=" not in text or not text.split("=", 1)[0].strip():
        raise argparse.ArgumentTypeError(
            f"expected PATH=VALUE, e.g. shapes[0].medium.sigma_t=1000, got {text!r}")
    return text


# The models `sssphere train` knows (learn.train.TIME_SHARES; repeated so that the command
# line is checked without importing torch).
_MODEL_NAMES = ("LengthGen", "PathGen", "EventGen")


def _model_names(text: str) -> tuple:
    """`sssphere train --models`: names from _MODEL_NAMES, comma-separated, each once."""
    names = [n.strip() for n in text.split(",")]
    bad = [n for n in names if n not in _MODEL_NAMES]
    if bad or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(
            f"expected model names from {','.join(_MODEL_NAMES)}, each at most once, got {text!r}")
    return tuple(names)


def _cmd_render(args: argparse.Namespace) -> int:
    from sssphere import _image

    out = Path(args.output)
    if args.turntable:
        _frame_pattern(args.output, args.turntable)
    outputs = ([args.output % k for k in range(args.turntable)] if args.turntable
               else [args.output])
    if args.aovs:  # the AOV files beside a .png (RenderResult.save)
        outputs += [f"{os.path.splitext(path)[0]}_{name}.exr" for path in outputs
                    if not path.lower().endswith(".exr") for name in rendering.AOV_LAYERS]
    # Before the render, not after it: the format, the directory, that a file can be made
    for path in outputs:
        _image.check_output_image(path)
    _check_ray(args.ray)
    # The render options as typed, checked and resolved in C++ with the scene's (one table
    # for both command lines and the API: render/options.h)
    text = {spec["name"]: getattr(args, spec["name"]) for spec in RENDER_OPTIONS
            if spec["command_line"] and getattr(args, spec["name"]) is not None}
    # Each value before the scene is read (their combinations after it, with the scene's):
    # a value out of range is a usage error, as --width 0 is
    try:
        _core.check_option_values(text)
    except SceneError as e:
        print(f"sssphere: error: {e}\n(sssphere render --help lists the options)",
              file=sys.stderr)
        return 2
    threads = int(text.get("threads", "0"))  # for the build
    t0 = time.monotonic()
    try:
        if not args.quiet and sys.stderr.isatty():  # the build can take seconds before the bar
            print(f"loading {args.scene} ...", file=sys.stderr, flush=True)
        with _said_warnings():
            scene = load_scene_with(args.scene, args.set, args.width, args.height, threads=threads)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the grid build stops at its next row
        print(f"interrupted while loading the scene: wrote nothing to {out}", file=sys.stderr)
        return _interrupted_status()
    load_s = time.monotonic() - t0
    for path in outputs:
        _image.check_output_is_not_an_input(path, [*scene.inputs, str(args.scene)])
    # the options' combinations with the scene's, said before a progress bar is drawn
    _core.resolve_render_options(scene, os.fspath(rendering.DEFAULT_MODELS), text)
    if args.denoise:  # a missing extra is said before the render, not after it
        try:
            rendering._denoiser()
        except ImportError as e:
            raise SystemExit(f"sssphere: error: --denoise: {e}") from None
    if args.turntable:
        return _render_turntable(args, scene, text, load_s)
    with _Signals() as signals:
        bar = Progress(f"rendering {Path(args.scene).name}", enabled=not args.quiet)
        with _said_warnings():
            try:
                result = rendering._result(
                    rendering._render(scene, signals.progress(bar), {}, text, args.ray))
            finally:
                bar.close()
        if result.interrupted and result.spp == 0:  # an all-black image would look like one
            print(f"interrupted before the first pass finished: wrote nothing to {out}",
                  file=sys.stderr)
            return _interrupted_status()
        result = rendering.with_aovs(scene, result, args.aovs, args.denoise)
        with _said_warnings():
            written = result.save(out, aovs=args.aovs)
    what = ("interrupted: wrote the partial image" if result.interrupted
            else "interrupted once the render had finished: wrote" if signals.count
            else "time limit reached: wrote" if result.time_limit_reached else "wrote")
    steps = ""
    if result.mean_sphere_steps_per_path > 0:
        step_ns = 1e9 * result.step_seconds / (result.mean_sphere_steps_per_path * result.samples.sum())
        steps = f" + {result.mean_sphere_steps_per_path:.1f} sphere steps" + (
            f" ({step_ns:.0f} ns each)" if result.step_seconds > 0 else "")
    aov_files = (f" and {len(written) - 1} AOV files beside it ({Path(written[1]).name}, ...)"
                 if len(written) > 1 else "")
    where = ""
    if result.cluster is not None:
        c = result.cluster
        nodes = len(c["nodes"])
        where = (f" on a Ray cluster: {c['tasks_merged']} tasks in {c['processes']} worker "
                 f"processes on {nodes} node{'' if nodes == 1 else 's'};")
    elif result.device:  # backend vulkan: which device (lavapipe is a CPU)
        where = f" on {result.device};"
    print(
        f"{what} {out}{aov_files} ({scene.width}x{scene.height}, {result.spp} spp;{where} "
        f"scene built in {load_s:.2f}s, "
        f"rendered in {result.seconds:.2f}s; {result.mean_events_per_path:.1f} scattering "
        f"events{steps} per path)",
        file=sys.stderr,
    )
    if not np.all(np.isfinite(result.image)):
        print("warning: the image has non-finite pixels", file=sys.stderr)
    return _interrupted_status() if result.interrupted or signals.count else 0


_FRAME_NUMBER = re.compile(r"%0?\d*d")


def _frame_pattern(output: str, frames: int) -> str:
    """The -o of --turntable: one printf-style frame number (%d, %03d); %% is a %."""
    rest = output.replace("%%", "")
    if len(_FRAME_NUMBER.findall(rest)) != 1 or rest.count("%") != 1:
        raise SceneError(f"{output}: --turntable {frames} writes one image per frame: give -o "
                         "a frame number pattern with one %d or %03d (and %% for a %), e.g. "
                         "frames/%03d.png")
    return output


def _render_turntable(args: argparse.Namespace, scene, text: dict, load_s: float) -> int:
    pattern = _frame_pattern(args.output, args.turntable)
    written = []

    def save(k: int, result) -> None:
        if result.spp == 0:  # interrupted before its first pass: nothing to keep
            return
        out = pattern % k
        result.save(out, aovs=args.aovs)
        written.append(out)

    bar = Progress(f"rendering {args.turntable} frames of {Path(args.scene).name}",
                   enabled=not args.quiet)
    t0 = time.monotonic()
    with _Signals() as signals, _said_warnings():
        try:
            results = rendering._render_frames(
                scene, rendering.orbit_cameras(scene, args.turntable), signals.progress(bar),
                save, args.aovs, args.denoise, text, args.ray, {}, keep=False)
        finally:
            bar.close()
    interrupted = bool(results) and results[-1].interrupted or signals.count > 0
    shown = written[0] + (f" ... {written[-1]}" if len(written) > 1 else "") if written else ""
    # the frame a stop cut short, if it was kept, with the passes it has
    last = results[-1] if results else None
    partial = (f"; the last, {written[-1]}, is partial: {last.spp} spp"
               if written and last.interrupted and last.spp > 0 else "")
    print(f"{'interrupted: wrote' if interrupted else 'wrote'} {len(written)} of "
          f"{args.turntable} frames {shown} ({scene.width}x{scene.height}; scene built in "
          f"{load_s:.2f}s, rendered in {time.monotonic() - t0:.2f}s{partial})", file=sys.stderr)
    return _interrupted_status() if interrupted else 0


def _check_ray(address) -> None:
    """--ray: Ray must be installed (said before any work is done)."""
    if address is None:
        return
    from sssphere import cluster

    try:
        cluster._ray()
    except ImportError as e:
        raise SystemExit(f"sssphere: error: --ray: {e}") from None


def _cmd_datagen(args: argparse.Namespace) -> int:
    from sssphere.learn.datagen import datagen

    _check_ray(args.ray)
    bar = Progress(f"simulating {args.samples} sphere walks", enabled=not args.quiet)
    try:
        data, interrupted, seconds = datagen(args.samples, args.output, seed=args.seed,
                                             threads=args.threads, progress=bar,
                                             ray_address=args.ray)
    except ValueError as e:
        raise SceneError(str(e)) from None
    finally:
        bar.close()
    n = len(data["N"])
    if interrupted and n == 0:
        print(f"interrupted before the first walks finished: wrote nothing to {args.output}",
              file=sys.stderr)
        return _interrupted_status()
    what = "interrupted: wrote the walks finished so far to" if interrupted else "wrote"
    print(f"{what} {args.output} ({n} walks in {seconds:.1f}s, {n / max(seconds, 1e-9):,.0f} "
          f"walks/s; mean N {data['N'].mean() if n else 0:.1f}, "
          f"P(N = 1) {np.mean(data['N'] == 1) if n else 0:.3f})", file=sys.stderr)
    return _interrupted_status() if interrupted else 0


def _learn_modules():
    """The torch side of sssphere.learn, or a clear error if the `learn` extra is missing."""
    try:
        from sssphere.learn import export, train
    except ImportError as e:
        raise SystemExit(f"sssphere: error: this command needs the 'learn' extra "
                         f"(pip install 'sssphere[learn]'): {e}") from None
    return train, export


def _cmd_train(args: argparse.Namespace) -> int:
    from sssphere.learn.data import DataError

    train, export = _learn_modules()
    try:
        train.train(args.data, args.output, epochs=args.epochs, seed=args.seed,
                    max_minutes=args.max_minutes, progress=not args.quiet, models=args.models)
    except (DataError, ValueError, FloatingPointError) as e:  # DataError: a bad data file
        print(f"sssphere: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as e:  # train() moves the files into place only when all are done
        print(_interrupted_write(e, export, args.output, "the models there are unchanged"),
              file=sys.stderr)
        if isinstance(e, train.InterruptedWithFinishedModels):
            resume = shlex.join(["sssphere", "train", str(args.data), "-o", str(e.partial),
                                 "--models", ",".join(e.missing)])
            print(f"sssphere: kept the finished {', '.join(e.finished)} in {e.partial}; "
                  f"{resume} trains the rest into it", file=sys.stderr)
        return _interrupted_status()
    if args.quiet:
        print(f"wrote the models to {args.output}", file=sys.stderr)
    return 0


def _interrupted_write(e: KeyboardInterrupt, export, output: str, unchanged: str) -> str:
    """What an interrupted train or export wrote: all of its files or none."""
    if isinstance(e, export.InterruptedAfterWrite):
        return f"\nsssphere: interrupted after all files were written to {output}"
    return f"\nsssphere: interrupted: wrote nothing to {output} ({unchanged})"


def _cmd_export(args: argparse.Namespace) -> int:
    _, export = _learn_modules()
    try:
        files = export.export_checkpoint(args.checkpoint, args.output)
    except export.CheckpointError as e:
        print(f"sssphere: error: {e}; wrote nothing to {args.output}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as e:  # export_checkpoint writes all files or none
        print(_interrupted_write(e, export, args.output, "the files there are unchanged"),
              file=sys.stderr)
        return _interrupted_status()
    print(f"wrote {', '.join(str(f) for f in files)}", file=sys.stderr)
    return 0


def _cmd_export_mitsuba(args: argparse.Namespace) -> int:
    from sssphere.mitsuba import export_mitsuba

    out = Path(args.output)
    if out.suffix.lower() != ".xml":
        raise SceneError(f"{out}: the Mitsuba scene is written as .xml, got {out.suffix!r}")
    if out.parent != Path("") and not out.parent.is_dir():
        raise SceneError(f"{out}: output directory {str(out.parent)!r} does not exist")
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        raise SceneError("export-mitsuba needs the mitsuba package (pip install mitsuba, or "
                         "the test extra: pip install 'sssphere[test]')") from None
    with _said_warnings():  # as render and info say them
        written = export_mitsuba(args.scene, out, spp=args.spp, seed=args.seed,
                                 integrator=args.integrator)
    print(f"wrote {written[0]} and {len(written) - 1} mesh file(s) in "
          f"{Path(written[-1]).parent if len(written) > 1 else out.parent}", file=sys.stderr)
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    from sssphere.info import format_info, scene_info

    with _said_warnings():
        scene = load_scene_with(args.scene, args.set, args.width, args.height)
    info = scene_info(scene)
    if args.json:
        import json

        print(json.dumps(info, indent=2))
    else:
        print(format_info(info))
    return 0


def _cmd_presets(args: argparse.Namespace) -> int:
    from sssphere.scene import presets

    def rgb(v):
        return " ".join(f"{x:10.4g}" for x in v)

    print(f"{'preset':28s} {'sigma_s_prime (mm^-1), R G B':>32s}  {'sigma_a (mm^-1), R G B':>32s}"
          f"  {'ior':>4s}  source")
    for p in presets():
        ior = f"{p['ior']:.1f}" if p["ior"] is not None else "-"
        print(f"{p['name']:28s} {rgb(p['sigma_s_prime'])}  {rgb(p['sigma_a'])}  {ior:>4s}  "
              f"{p['source']}")
    print('\nIn a medium: {"preset": NAME, "scale": scene units per mm, "g": ...}; '
          "sigma_s = sigma_s_prime / (1 - g).")
    return 0


def _cmd_eval(args: argparse.Namespace) -> int:
    from sssphere.learn import evaluate
    from sssphere.model import DEFAULT_MODELS

    # The shipped models by default, wherever the command runs (as render finds them).
    models = Path(args.models) if args.models is not None else DEFAULT_MODELS
    if not models.is_dir():
        raise SceneError(f"{models}: models directory does not exist (--models: a directory "
                         "with lengthgen.json, pathgen.json and eventgen.json)")
    # Beside the models named, else here: never into the installed package's models
    out = Path(args.out) if args.out else models if args.models is not None else Path(".")
    if args.out and not out.exists():  # as train's --output
        try:
            out.mkdir(parents=True)
        except OSError as e:
            raise SceneError(f"{out}: cannot create the output directory: "
                             f"{e.strerror}") from None
    if not out.is_dir():
        raise SceneError(f"{out}: is a file, not an output directory"
                         if out.exists() else f"{out}: output directory does not exist")
    if not os.access(out, os.W_OK):
        raise SceneError(f"{out}: output directory is not writable (--out chooses another)")
    if args.update_card:  # told now, not after minutes of evaluation
        try:
            evaluate.check_model_card(out / "README.md")
        except ValueError as e:
            raise SceneError(str(e)) from None
    try:
        if args.decoder == "numpy":
            from sssphere.learn.numpy_decoder import SphereSampler

            sampler = SphereSampler.from_dir(models)

            def sample_fn(sigma_t, g, albedo, n, seed):
                return sampler.sample(sigma_t, g, albedo, n, np.random.default_rng(seed))
        else:
            from sssphere.model import ScatteringModel

            model = ScatteringModel.load(models)

            def sample_fn(sigma_t, g, albedo, n, seed):
                return model.sample(sigma_t, g, albedo, n, seed=seed)
    except ValueError as e:  # ModelFileError and the C++ loader's errors name the file
        raise SceneError(str(e)) from None
    try:  # a cell outside the models' ranges: told now, not after the cells before it
        for sigma in evaluate.SIGMAS:
            for g in evaluate.GS:
                sample_fn(sigma, g, evaluate.ALBEDO, 1, 0)
    except ValueError as e:
        raise SceneError(f"{models}: the evaluation grid (sigma_t {list(evaluate.SIGMAS)}, g "
                         f"{list(evaluate.GS)}) lies outside these models' training ranges: "
                         f"{e}") from None
    bar = Progress("evaluating 16 cells", enabled=not args.quiet)
    try:
        cells = evaluate.evaluate(sample_fn, samples=args.samples, seed=args.seed, progress=bar)
    finally:
        bar.close()
    table = evaluate.table_markdown(cells)
    print(table)
    report = evaluate.write_report(cells, out, args.samples, str(models), args.decoder, args.seed)
    figures = [] if args.no_plots else evaluate.plot(cells, out)
    if args.update_card:
        evaluate.update_model_card(out / "README.md", table)
    worst = max(max(c.ks["log_N"], c.ks["cos_theta"]) for c in cells)
    print(f"wrote {report}" + "".join(f", {f}" for f in figures)
          + f"; worst KS of log N and cos theta: {worst:.3f} (aim {evaluate.TARGET_KS})",
          file=sys.stderr)
    return 0


def _cmd_calibrate_tilt(args: argparse.Namespace) -> int:
    from sssphere.learn import tilt
    from sssphere.model import ScatteringModel

    models = Path(args.models)
    try:
        model = ScatteringModel.load(models, tilt=False)
    except ValueError as e:
        raise SceneError(str(e)) from None
    out = Path(args.output) if args.output else models / "tilt.json"
    if out.is_dir():
        raise SceneError(f"{out}: is a directory, not a tilt file (-o: the file to write)")
    if not out.parent.is_dir() or not os.access(out.parent, os.W_OK):
        raise SceneError(f"{out.parent}: output directory does not exist or is not writable")
    bar = Progress("calibrating the tilt", enabled=not args.quiet)
    try:
        result = tilt.calibrate(model, seed=args.seed, progress=bar)
    finally:
        bar.close()
    print(f"wrote {tilt.write(result, out)}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sssphere", description=__doc__)
    parser.add_argument("--version", action="version", version=f"sssphere {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a scene file to an image")
    r.add_argument("scene", help="scene file (JSON, docs/scene-format.md)")
    r.add_argument("-o", "--output", required=True, help="output image (.exr linear, .png sRGB)")
    r.add_argument("--version", action="version", version=f"sssphere {__version__}")
    for spec in RENDER_OPTIONS:  # the table both command lines are built from
        if not spec["command_line"]:
            continue
        flag = spec["name"].replace("_", "-")
        if spec["kind"] == "flag":
            r.add_argument(f"--no-{flag}", dest=spec["name"], action="store_const", const="false",
                           help=f"turn off {spec['help']}")
        else:
            r.add_argument(f"--{flag}", dest=spec["name"], metavar=spec["metavar"], help=spec["help"])
    r.add_argument("--aovs", action="store_true",
                   help="also write the variance, scattering events per path, sphere steps "
                        "(st), first-hit albedo, normal and depth: as layers of OUT for an "
                        ".exr, as OUT_NAME.exr files beside a .png")
    r.add_argument("--denoise", action="store_true",
                   help="write the image denoised by Intel Open Image Denoise with the albedo "
                        "and normal AOVs (needs pip install 'sssphere[denoise]'); with --aovs "
                        "the estimate is kept as the layer 'noisy'")
    r.add_argument("--turntable", type=_positive_int, metavar="N",
                   help="render N frames on a circle about the camera's target (about its up "
                        "axis); -o is then a frame number pattern such as frames/%%03d.png")
    r.add_argument("--ray", metavar="ADDRESS",
                   help="render on the Ray cluster at ADDRESS (auto: the one in RAY_ADDRESS or "
                        "running on this machine; HOST:PORT; docs/cluster.md); --threads is "
                        "then each task's (default 1). Needs pip install 'sssphere[cluster]'")
    r.add_argument("--set", action="append", metavar="PATH=VALUE", type=_assignment,
                   help="change a scene field before loading, e.g. --set "
                        "shapes[0].medium.sigma_t=1000 or --set 'camera.origin=[0, 1, 3]' "
                        "(VALUE is JSON, else a string; repeatable)")
    r.add_argument("--width", type=_image_size,
                   help="image width (alone: the height follows the scene's aspect ratio)")
    r.add_argument("--height", type=_image_size,
                   help="image height (alone: the width follows the scene's aspect ratio)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=_cmd_render)

    d = sub.add_parser("datagen", help="simulate sphere walks as training data (.npz)")
    d.add_argument("--samples", type=_positive_int, default=4_000_000,
                   help="number of walks (default 4,000,000)")
    d.add_argument("-o", "--output", required=True, help="output file (.npz)")
    d.add_argument("--seed", type=_non_negative_int, default=0, help="random seed (default 0)")
    d.add_argument("--threads", type=_non_negative_int, default=0, help="worker threads (0 = all cores)")
    d.add_argument("--ray", metavar="ADDRESS",
                   help="simulate on the Ray cluster at ADDRESS, in tasks of 20,000 walks: the "
                        "same file as a local run (docs/cluster.md)")
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.set_defaults(func=_cmd_datagen)

    t = sub.add_parser("train", help="train the three CVAEs on walks of the sphere problem "
                                     "(docs/learning.md) and write the model files")
    t.add_argument("data", help="training-data file (.npz: sigma, g, phi, N, cos_theta, alpha, "
                                "beta, X, W)")
    t.add_argument("-o", "--output", required=True,
                   help="directory for lengthgen/pathgen/eventgen .json + .onnx and "
                        "cvae_checkpoint.pt (created if missing)")
    t.add_argument("--epochs", type=_positive_int, help="passes over the data per model "
                                                        "(default: the shipped models' setting)")
    t.add_argument("--seed", type=_non_negative_int, default=0, help="random seed (default 0)")
    t.add_argument("--models", type=_model_names, default=_MODEL_NAMES,
                   help="comma-separated models to train (default: "
                        "LengthGen,PathGen,EventGen); the others' .json and .onnx stay as they "
                        "are, cvae_checkpoint.pt then holds these alone")
    t.add_argument("--max-minutes", type=_positive_float,
                   help="wall-clock limit for all the models trained (the schedules follow the "
                        "clock)")
    t.add_argument("--quiet", action="store_true", help="no progress bars or summary")
    t.set_defaults(func=_cmd_train)

    x = sub.add_parser("export", help="write the model files (.json + .onnx) of a training "
                                      "checkpoint again")
    x.add_argument("checkpoint", help="cvae_checkpoint.pt written by `sssphere train`")
    x.add_argument("-o", "--output", required=True, help="output directory (created if missing)")
    x.set_defaults(func=_cmd_export)

    i = sub.add_parser("info", help="a scene in brief: shapes, grids, media, and the scattering "
                                     "events and sphere steps to expect per path")
    i.add_argument("scene", help="scene file (JSON, docs/scene-format.md)")
    i.add_argument("--set", action="append", metavar="PATH=VALUE", type=_assignment,
                   help="change a scene field first, as for render (repeatable)")
    i.add_argument("--width", type=_image_size, help="image width, as for render")
    i.add_argument("--height", type=_image_size, help="image height, as for render")
    i.add_argument("--json", action="store_true", help="print the figures as JSON")
    i.set_defaults(func=_cmd_info)

    m = sub.add_parser("export-mitsuba", help="write the equivalent Mitsuba 3 scene (.xml and "
                                              "PLY meshes) of a scene file, to compare the two")
    m.add_argument("scene", help="scene file (JSON, docs/scene-format.md)")
    m.add_argument("output", help="Mitsuba scene (.xml); meshes go to OUTPUT_STEM_meshes/")
    m.add_argument("--spp", type=_positive_int, default=64, help="samples per pixel (default 64)")
    m.add_argument("--seed", type=_mitsuba_seed, default=0, help="sampler seed, 0 to 2^32 - 1 (default 0)")
    m.add_argument("--integrator", choices=["volpath", "volpathmis"],
                   help="Mitsuba's integrator (default: volpathmis, spectral MIS, where a "
                        "medium's sigma_t differs between channels, which volpath converges "
                        "on too slowly to compare with; else volpath)")
    m.set_defaults(func=_cmd_export_mitsuba)

    e = sub.add_parser("eval", help="compare the learned models with ground-truth walks")
    e.add_argument("--models", default=None,
                   help="directory of the model files (default: the shipped models)")
    e.add_argument("--samples", type=_positive_int, default=10_000,
                   help="walks per cell (default 10,000)")
    e.add_argument("--seed", type=_non_negative_int, default=0,
                   help="seed of the walks and model samples (default 0)")
    e.add_argument("--out", help="where eval.json and the figures go (default: --models if given, else the "
                        "current directory)")
    e.add_argument("--decoder", choices=("cpp", "numpy"), default="cpp",
                   help="the C++ decoders the renderer uses, or the NumPy reference")
    e.add_argument("--update-card", action="store_true",
                   help="write the table into OUT/README.md between the eval markers")
    e.add_argument("--no-plots", action="store_true", help="skip the figures")
    e.add_argument("--quiet", action="store_true", help="no progress bar")
    e.set_defaults(func=_cmd_eval)

    c = sub.add_parser("calibrate-tilt", help="fit PathGen's forward-memory tilt (tilt.json) "
                       "against exact walks (docs/sphere-tracing.md)")
    c.add_argument("--models", required=True,
                   help="directory of the model files; tilt.json is written there")
    c.add_argument("-o", "--output", help="the tilt file to write (default: MODELS/tilt.json)")
    c.add_argument("--seed", type=_tilt_seed, default=11,
                   help="seed of the model samples (the walks take seed + 1; default 11)")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.set_defaults(func=_cmd_calibrate_tilt)

    p = sub.add_parser("presets", help="list the measured media a scene's medium can name")
    p.set_defaults(func=_cmd_presets)
    return parser


# SIGTERM (kill, batch schedulers, container runtimes) and SIGHUP (a closed terminal, an ssh
# session that dropped) stop a long command as Ctrl-C does: the work done so far is written,
# and the exit status is 128 + the signal (143, 129) instead of 130.
_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_stopped_by = 0  # the signal other than SIGINT that stopped the command, if any


def _note_stop(signum: int) -> None:
    global _stopped_by
    if signum != signal.SIGINT:
        _stopped_by = _stopped_by or signum
    if signum == signal.SIGHUP:  # no terminal to write to: writes to it would fail (EIO)
        devnull = os.open(os.devnull, os.O_WRONLY)
        for fd in (1, 2):
            os.dup2(devnull, fd)
        os.close(devnull)


def _on_sigterm(signum, frame):
    _note_stop(signum)
    raise KeyboardInterrupt


class _Signals:
    """SIGINT, SIGTERM and SIGHUP while a render runs and its image is written. The first stops the
    render at its next progress check (about ten times a second), as Ctrl-C does in the
    API; neither raises, so the image rendered so far is still written whole, however late
    the signal comes (a render that had finished, its AOVs, the denoiser, the write) and if
    it comes twice. After the second the signals' default actions are back: a third ends
    the process, for a write that hangs. A signal the process was started ignoring (a
    background job's SIGINT) stays ignored."""

    def __init__(self):
        self.count = 0

    def __enter__(self) -> "_Signals":
        self._previous = {}
        for s in _STOP_SIGNALS:
            if signal.getsignal(s) is not signal.SIG_IGN:  # nohup's SIGHUP stays ignored
                self._previous[s] = signal.signal(s, self._on_signal)
        return self

    def __exit__(self, *exc) -> None:
        for s, handler in self._previous.items():
            signal.signal(s, handler)

    def _on_signal(self, signum, frame) -> None:
        _note_stop(signum)
        self.count += 1
        if self.count == 2:
            for s in self._previous:
                signal.signal(s, signal.SIG_DFL)
            # os.write: a print here could interrupt the progress bar's own write
            os.write(2, b"\nsssphere: interrupted again: still writing what was rendered "
                        b"(once more ends it at once)\n")

    def progress(self, bar: Progress):
        """bar as a render's progress callback that also stops the render once signalled."""
        return lambda fraction: bar(fraction) is not False and self.count == 0


def _stdout_reader_gone() -> bool:
    """Whether stdout is a pipe whose reading end is closed (poll reports an error on the
    writing end then)."""
    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & select.POLLERR for _, events in poll.poll(0))
    except (OSError, ValueError, AttributeError):
        return False


def _interrupted_status() -> int:
    return 128 + _stopped_by if _stopped_by else 130


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    for s in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, _on_sigterm)
    try:
        status = args.func(args)
        sys.stdout.flush()  # here, where a closed pipe is caught below, not at exit
        return status
    except BrokenPipeError as e:
        if not _stdout_reader_gone():  # another pipe (a cluster connection, a FIFO)
            print(f"sssphere: error: {e}", file=sys.stderr)
            return 1
        # The reader of our output left (`sssphere presets | head`): quiet, as a command
        # killed by SIGPIPE; stdout to /dev/null so that Python's own flush at exit does
        # not complain again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except (SceneError, OSError) as e:  # OSError: a path that cannot be written, a lost cluster
        print(f"sssphere: error: {e}", file=sys.stderr)
        return 1
    except MemoryError as e:  # inputs name themselves (read_input_file); this is the rest
        print(f"sssphere: error: out of memory{f' ({e})' if str(e) else ''}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # outside the work that stops by itself and says what it kept
        print("sssphere: interrupted", file=sys.stderr)
        return _interrupted_status()


if __name__ == "__main__":
    sys.exit(main())
