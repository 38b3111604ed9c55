"""Writing trained decoders as model files (docs/model-format.md) and ONNX, and the training
checkpoint that lets `sssphere export` write them again without retraining.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import math
import os
import shutil
import signal
import sys
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np
import torch

from sssphere._files import atomic_output, missing_input
from sssphere.learn.models import CVAE, GaussianMLP
from sssphere.learn.spec import (FORMAT, FORMAT_VERSION, NOTATION_VERSION, SPECS, SPECS_BY_NAME,
                                 Encoding, ModelSpec, round9)

ONNX_OPSET = 20
CHECKPOINT_FORMAT = "sssphere-cvae-checkpoint"
CHECKPOINT_VERSION = 1


class CheckpointError(ValueError):
    """A checkpoint is missing, unreadable or of another format."""


class InterruptedAfterWrite(KeyboardInterrupt):
    """Ctrl-C or SIGTERM that came while `staged_output` moved the finished files into place:
    it was held until all were there, so the output is complete."""


# --------------------------------------------------------------------------------------
# JSON
# --------------------------------------------------------------------------------------
def _clean(obj, where: str = ""):
    """JSON-ready copy: numpy scalars and arrays to Python, floats to 9 significant digits.
    `where`: the field's path in the file, for the error message."""
    if isinstance(obj, dict):
        return {str(k): _clean(v, f"{where}.{k}" if where else str(k)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist(), where)
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        if not math.isfinite(obj):
            raise ValueError(f"{where or 'a value'} is {obj}: a model file holds finite "
                             "numbers only")
        return round9(obj)
    if obj is None or isinstance(obj, str):
        return obj
    raise TypeError(f"cannot write {type(obj).__name__} ({where}) to a model file")


def _dumps(obj, indent: int = 0) -> str:
    """JSON with 2-space indentation, but a list of numbers on one line."""
    pad, inner = "  " * indent, "  " * (indent + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{inner}{json.dumps(k)}: {_dumps(v, indent + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list):
        if all(isinstance(v, (int, float, str, bool)) or v is None for v in obj):
            return "[" + ", ".join(json.dumps(v, allow_nan=False) for v in obj) + "]"
        return "[\n" + ",\n".join(inner + _dumps(v, indent + 1) for v in obj) + "\n" + pad + "]"
    return json.dumps(obj, allow_nan=False)


def decoder_json(spec: ModelSpec, decoder: GaussianMLP, encodings: dict, training: dict,
                 metrics: dict | None) -> dict:
    """The model-file object of a decoder (float32 weights written with 9 digits)."""
    layers = []
    linear = decoder.linear_layers()
    for i, layer in enumerate(linear):
        w = layer.weight.detach().to(torch.float32).numpy()
        b = layer.bias.detach().to(torch.float32).numpy()
        for field, values in (("weight", w), ("bias", b)):
            bad = ~np.isfinite(values)
            if bad.any():
                raise ValueError(f"layers[{i}].{field} holds {int(bad.sum())} non-finite "
                                 f"value(s) (first {values[bad].flat[0]}); a model file "
                                 "holds finite numbers only")
        layers.append({
            "in": int(w.shape[1]),
            "out": int(w.shape[0]),
            "activation": "identity" if i == len(linear) - 1 else "softplus",
            "weight": [[float(f"{v:.9g}") for v in row] for row in w],
            "bias": [float(f"{v:.9g}") for v in b],
        })
    obj = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "notation_version": NOTATION_VERSION,
        "name": spec.name,
        "conditions": [{"name": n, "encode": encodings[n].to_json()} for n in spec.conditions],
        "latent_dim": spec.latent_dim,
        "input_width": spec.input_width,
        "layers": layers,
        "outputs": [{"name": n, "encode": encodings[n].to_json()} for n in spec.outputs],
        "training": training,
    }
    if metrics is not None:
        obj["metrics"] = metrics
    return _clean(obj)


# --------------------------------------------------------------------------------------
# ONNX
# --------------------------------------------------------------------------------------
class _DropTorchvisionNotice(logging.Filter):
    """The exporter logs one warning per torchvision operator when torchvision is not
    installed; our decoders use none of them."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("torchvision is not installed")


def export_onnx(decoder: GaussianMLP, input_width: int, path) -> None:
    """`path`: input ``x`` (batch, input_width) → outputs ``mean``, ``logvar``; opset 20."""
    decoder = decoder.eval()
    example = torch.zeros(2, input_width)
    registration_log = logging.getLogger("torch.onnx._internal.exporter._registration")
    notice_filter = _DropTorchvisionNotice()
    registration_log.addFilter(notice_filter)
    try:
        _export(decoder, example, path)
    finally:
        registration_log.removeFilter(notice_filter)


def _export(decoder: GaussianMLP, example: torch.Tensor, path) -> None:
    with warnings.catch_warnings():
        # torch 2.13's exporter calls its own deprecated pytree API (torch/utils/_pytree.py,
        # through copyreg); the warning is about torch's internals, not about this model.
        warnings.filterwarnings("ignore", category=FutureWarning,
                                message=r"`isinstance\(treespec, LeafSpec\)` is deprecated")
        program = torch.onnx.export(
            decoder, (example,), input_names=["x"], output_names=["mean", "logvar"],
            opset_version=ONNX_OPSET, dynamo=True, verbose=False,
            dynamic_shapes=({0: torch.export.Dim("batch")},),
        )
    # The exporter records each node's Python stack trace, absolute paths of this checkout
    # included: dropped, so a file depends on the weights alone, not on where it was made.
    for node in program.model.graph:
        node.metadata_props.pop("pkg.torch.onnx.stack_trace", None)
    program.save(str(path))


# --------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------
def prepare_output_dir(out_dir, names) -> bool:
    """Create out_dir if missing and check that the files `names` can be written there, so
    that a bad output is told before minutes of training, not after. Returns whether the
    directory was created."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OSError(f"{out}: is a file, not a directory (the models are written into a "
                      "directory)")
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OSError(f"{out}: cannot create the output directory ({e.strerror})") from None
    for name in names:
        p = out / name
        if (p.exists() or p.is_symlink()) and not p.is_file():
            raise OSError(f"{p}: is a directory or other non-file where the output file "
                          f"{name} is to be written (move it away first)")
    return created


@contextlib.contextmanager
def staged_output(out_dir, names):
    """Yield a hidden directory inside out_dir for all the files `names` of one run; when the
    block succeeds they are moved into out_dir together, on an exception (Ctrl-C included)
    none is, so out_dir never holds a mix of old and new models. A directory that this call
    created is removed again if the run fails."""
    out = Path(out_dir)
    created = prepare_output_dir(out, names)
    stage = Path(tempfile.mkdtemp(prefix=".sss-staging-", dir=out))
    ok, held = False, []
    try:
        yield stage
        missing = [n for n in names if not (stage / n).is_file()]
        if missing:
            raise RuntimeError(f"internal error: {', '.join(missing)} not written")
        # The renames are quick, but a signal between two would still mix the sets: hold
        # SIGINT and SIGTERM until all are done, then deliver them. (Python-level handlers:
        # a signal mask is per thread, and torch's threads would take the signal.)
        previous = {}
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGINT, signal.SIGTERM):
                if signal.getsignal(s) not in (signal.SIG_IGN, None):
                    previous[s] = signal.signal(s, lambda signum, frame: held.append(signum))
        try:
            # A tilt fitted to the decoders being replaced would skew the new ones' steps
            # (docs/model-format.md, "tilt.json"): moved aside first, never left with them.
            stale = out / "tilt.json"
            if {"lengthgen.json", "pathgen.json"} & set(names) and stale.is_file():
                os.replace(stale, out / "tilt.json.stale")
                print(f"{stale}: fitted to the models this run replaced; moved to "
                      f"tilt.json.stale (sssphere calibrate-tilt --models {out} fits the new "
                      "ones)", file=sys.stderr)
            for name in names:
                os.replace(stage / name, out / name)
            ok = True
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if created and not ok:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty
    if held:  # delivered once the stage is gone (a signal's default action ends the process)
        try:
            signal.raise_signal(signal.SIGTERM if signal.SIGTERM in held else held[0])
        except KeyboardInterrupt:
            raise InterruptedAfterWrite from None


def write_model(out_dir, spec: ModelSpec, model: CVAE, encodings: dict, training: dict,
                metrics: dict | None) -> list[Path]:
    """Write ``<stem>.json`` and ``<stem>.onnx`` of a trained model into out_dir."""
    out = Path(out_dir)
    obj = decoder_json(spec, model.decoder, encodings, training, metrics)
    json_path = out / f"{spec.file_stem}.json"
    with atomic_output(json_path) as tmp:
        tmp.write_text(_dumps(obj) + "\n", encoding="utf-8")
    onnx_path = out / f"{spec.file_stem}.onnx"
    with atomic_output(onnx_path) as tmp:
        export_onnx(model.decoder, spec.input_width, tmp)
    return [json_path, onnx_path]


def save_checkpoint(path, trained: dict) -> Path:
    """trained: name → (model, encodings, training, metrics). Tensors and plain data only, so
    `torch.load(weights_only=True)` reads it."""
    blob = {"format": CHECKPOINT_FORMAT, "version": CHECKPOINT_VERSION, "models": {}}
    for name, (model, enc, training, metrics) in trained.items():
        blob["models"][name] = {
            "state_dict": {k: v.detach().clone() for k, v in model.state_dict().items()},
            "encodings": {k: e.to_json() for k, e in enc.items()},
            "training": json.loads(json.dumps(_clean(training, "training"))),
            "metrics": json.loads(json.dumps(_clean(metrics, "metrics"))),
        }
    buf = io.BytesIO()
    torch.save(blob, buf)
    with atomic_output(path) as tmp:
        tmp.write_bytes(buf.getvalue())
    return Path(path)


def load_checkpoint(path) -> dict:
    """name → (model, encodings, training, metrics), as `save_checkpoint` got them."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: {missing_input(path, 'checkpoint')}")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # torch raises many kinds (pickle, zip, runtime) for a bad file
        raise CheckpointError(f"{path}: not a readable checkpoint "
                              f"({type(e).__name__}: {e})") from None
    if not isinstance(blob, dict) or blob.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(f"{path}: not an sssphere CVAE checkpoint")
    if blob.get("version") != CHECKPOINT_VERSION:
        raise CheckpointError(f"{path}: checkpoint version {blob.get('version')!r}, this reader "
                              f"understands {CHECKPOINT_VERSION}")
    models = blob.get("models")
    if not isinstance(models, dict):
        raise CheckpointError(f"{path}: the checkpoint holds no models (no 'models' table)")
    out = {}
    for name, entry in models.items():
        spec = SPECS_BY_NAME.get(name)
        if spec is None:
            raise CheckpointError(f"{path}: unknown model {name!r}")
        try:  # a checkpoint of other layer widths, or missing a part: named, no traceback
            model = CVAE(spec)
            model.load_state_dict(entry["state_dict"])
            enc = {k: Encoding.from_json(v) for k, v in entry["encodings"].items()}
            missing = [v for v in (*spec.conditions, *spec.outputs) if v not in enc]
            if missing:
                raise KeyError(f"no encoding of {', '.join(missing)}")
            out[name] = (model.eval(), enc, entry["training"], entry["metrics"])
        except (KeyError, TypeError, ValueError, RuntimeError) as e:
            lines = [line.strip() for line in str(e).splitlines() if line.strip()]
            why = " ".join(lines[:2])[:300] or type(e).__name__
            raise CheckpointError(f"{path}: model {name}: not the {name} this version "
                                  f"builds ({type(e).__name__}: {why})") from None
    return out


def export_checkpoint(checkpoint, out_dir) -> list[Path]:
    """Write the model files (JSON + ONNX) of every model in a checkpoint: all of them or,
    on any error, none (out_dir is then as it was)."""
    out = Path(out_dir)
    trained = load_checkpoint(checkpoint)
    specs = [spec for spec in SPECS if spec.name in trained]
    # Every model file's JSON first: a bad number is told before anything is written.
    for spec in specs:
        model, enc, training, metrics = trained[spec.name]
        try:
            decoder_json(spec, model.decoder, enc, training, metrics)
        except ValueError as e:
            raise CheckpointError(f"{checkpoint}: model {spec.name}: {e}") from None
    names = [f"{spec.file_stem}.{ext}" for spec in specs for ext in ("json", "onnx")]
    with staged_output(out, names) as stage:
        for spec in specs:
            model, enc, training, metrics = trained[spec.name]
            write_model(stage, spec, model, enc, training, metrics)
    return [out / n for n in names]
