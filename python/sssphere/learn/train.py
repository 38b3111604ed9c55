"""Training the three CVAEs on a training-data file (docs/learning.md).

    from sssphere.learn.train import train
    summary = train("walks.npz", "models/", epochs=4, seed=0)

writes ``models/lengthgen.json`` / ``.onnx``, ``pathgen.*``, ``eventgen.*`` (the contract of
docs/model-format.md) and ``models/cvae_checkpoint.pt`` (encoders included, for `export`).

Loss per sample: the negative ELBO, Σ_i −ln N(x_i; μ_i, e^{ℓ_i}) + β·Σ_j max(λ, KL_j), with
KL_j the batch mean of the latent dimension j's KL to N(0, 1), λ the free bits per dimension
and β the KL warm-up weight (0 → 1 over the first `kl_warmup` of training). Optimiser AdamW,
learning rate warmed up linearly and then cosine-annealed to `lr_final`. Everything is seeded:
the same data, seed, thread count and settings give the same weights, unless `max_minutes`
cuts training short (then the schedule follows the clock and the result depends on speed).
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from sssphere._progress import Progress
from sssphere.learn.data import DataError, TrainingData, load_training_data
from sssphere.learn.models import CVAE, gaussian_nll, kl_per_dim
from sssphere.learn.spec import (BASE_ENCODINGS, CUT_SPECS, ENCODING_SETS, SPECS, Encoding,
                                 ModelSpec)

# Share of a `max_minutes` budget per model, roughly their cost per sample.
TIME_SHARES = {"LengthGen": 0.2, "PathGen": 0.35, "EventGen": 0.45}
ACTIVE_LATENT_NATS = 0.01  # a latent dimension "is used" above this mean KL


@dataclass
class TrainConfig:
    """Hyperparameters (defaults: the shipped models)."""

    epochs: int = 100
    batch_size: int = 4096
    lr: float = 3e-3
    lr_final: float = 3e-5
    lr_warmup_steps: int = 200
    weight_decay: float = 1e-5
    free_bits: float = 0.0  # λ, nats per latent dimension (batch mean); 0: warm-up only
    kl_warmup: float = 0.15  # fraction of training over which β goes 0 → 1
    grad_clip: float = 10.0
    val_fraction: float = 0.02
    max_val: int = 50_000
    event_jitter: float = 0.0  # std. dev. of Gaussian noise added to EventGen's X, W targets
    encodings: str = "logit"  # "logit" (shipped) or "plain" (affine/log only), spec.ENCODING_SETS
    threads: int = 1

    def __post_init__(self):
        """Refuse values that would train nothing, divide by zero or silently mean something
        else (a negative batch size trained 0 steps and reported success)."""
        def need(name: str, ok, allowed: str, integer: bool = False):
            v = getattr(self, name)
            number = isinstance(v, (int, float)) and not isinstance(v, bool)
            if not number or (integer and not float(v).is_integer()) or not ok(v):
                raise ValueError(f"TrainConfig.{name} = {v!r} is not allowed "
                                 f"(allowed: {allowed})")

        finite = math.isfinite
        need("epochs", lambda v: v >= 1, "an integer >= 1", integer=True)
        need("batch_size", lambda v: v >= 1, "an integer >= 1", integer=True)
        need("lr", lambda v: finite(v) and v > 0, "a number > 0")
        need("lr_final", lambda v: finite(v) and v >= 0, "a number >= 0")
        need("lr_warmup_steps", lambda v: v >= 1, "an integer >= 1", integer=True)
        need("weight_decay", lambda v: finite(v) and v >= 0, "a number >= 0")
        need("free_bits", lambda v: finite(v) and v >= 0, "a number >= 0 (nats)")
        need("kl_warmup", lambda v: 0 <= v <= 1, "a fraction of training, 0 to 1")
        need("grad_clip", lambda v: finite(v) and v >= 0, "a number >= 0 (0: no clipping)")
        need("val_fraction", lambda v: 0 <= v < 1, "0 <= val_fraction < 1")
        need("max_val", lambda v: v >= 0, "an integer >= 0", integer=True)
        need("event_jitter", lambda v: finite(v) and v >= 0, "a number >= 0")
        need("threads", lambda v: v >= 1, "an integer >= 1", integer=True)
        if self.encodings not in ENCODING_SETS:
            raise ValueError(f"TrainConfig.encodings = {self.encodings!r} is not allowed "
                             f"(allowed: {', '.join(ENCODING_SETS)})")


# --------------------------------------------------------------------------------------
# Data → encoded tensors
# --------------------------------------------------------------------------------------
def _columns(data: TrainingData, names) -> np.ndarray:
    cols = []
    for name in names:
        if len(name) == 3 and name[1] == "_" and name[2] in "xyz":  # X_x: column x of X
            cols.append(getattr(data, name[0])[:, "xyz".index(name[2])])
        else:
            cols.append(np.asarray(getattr(data, name), dtype=np.float64))
    return np.stack(cols, axis=1)


def fit_encodings(spec: ModelSpec, data: TrainingData, rng: np.random.Generator,
                  which: str = "logit") -> dict:
    """Per variable: its encoding of spec.ENCODING_SETS[which], standardized on the data
    (LengthGen's N on the dequantized N + ξ)."""
    if which not in ENCODING_SETS:
        raise ValueError(f"unknown encoding set {which!r} (allowed: {', '.join(ENCODING_SETS)})")
    base = ENCODING_SETS[which]
    check_conditions_vary(data, spec.conditions, spec.name)
    enc = {}
    for name in spec.conditions:
        enc[name] = base[name].standardized(_columns(data, [name])[:, 0])
    for name in spec.outputs:
        x = _columns(data, [name])[:, 0]
        if _dequantized(spec):
            x = x + rng.random(x.shape[0])
        enc[name] = base[name].standardized(x)
    return enc


# Below this spread (std of the encoded variable, relative to its magnitude) a condition is
# taken as constant: float32 rounding of one value leaves a std of ~1e-16, and standardizing
# on it blew LengthGen's loss up to 1e11 and PathGen's to nan.
MIN_RELATIVE_SPREAD = 1e-6


def check_conditions_vary(data: TrainingData, names, model: str | None = None) -> None:
    """Refuse a condition that is (nearly) constant over the walks: a model cannot learn how
    the walks depend on a variable it never sees change."""
    for name in names:
        e = BASE_ENCODINGS[name].encode(_columns(data, [name])[:, 0])
        spread = float(np.std(e))
        if not spread > MIN_RELATIVE_SPREAD * max(1.0, abs(float(np.mean(e)))):
            v = _columns(data, [name])[:, 0]
            raise DataError(
                f"{data.path}: {name} is constant over the {len(data)} walks"
                f"{f' that {model} trains on' if model else ''} ({name} from "
                f"{float(v.min()):.9g} to {float(v.max()):.9g}); the data must span a range "
                "of media, as `sssphere datagen` makes")


def _dequantized(spec: ModelSpec) -> bool:
    """Models of N alone (LengthGen, CutLengthGen) learn the dequantized N + ξ."""
    return spec.outputs == ("N",)


def _seed_index(spec: ModelSpec) -> int:
    """Distinct per model: its place in SPECS, then in CUT_SPECS (seeds of the shipped three
    unchanged)."""
    return (SPECS + CUT_SPECS).index(spec)


def _encode_torch(e: Encoding, x: torch.Tensor) -> torch.Tensor:
    if e.kind == "affine":
        return e.a * x + e.b
    if e.kind == "log":
        return e.a * torch.log(e.s * x + e.c) + e.b
    # Jittered targets may step past the ends: keep them inside the domain (lo − ε, hi + ε).
    x = torch.clamp(x, e.lo - 0.5 * e.eps, e.hi + 0.5 * e.eps)
    return e.a * (torch.log(x - e.lo + e.eps) - torch.log(e.hi - x + e.eps)) + e.b


class _Batches:
    """Encoded conditions (fixed) and raw outputs, encoded per batch after the model's noise:
    dequantization N + ξ (LengthGen) or Gaussian jitter (EventGen)."""

    def __init__(self, spec: ModelSpec, data: TrainingData, enc: dict, cfg: TrainConfig):
        self.spec = spec
        cond = np.stack([enc[n].encode(_columns(data, [n])[:, 0]) for n in spec.conditions], 1)
        self.c = torch.from_numpy(cond.astype(np.float32))
        self.x_raw = torch.from_numpy(_columns(data, spec.outputs))  # float64: N up to 1e5
        self.out_enc = [enc[n] for n in spec.outputs]
        self.jitter = cfg.event_jitter if spec.name == "EventGen" else 0.0

    def __len__(self) -> int:
        return self.c.shape[0]

    def get(self, idx: torch.Tensor, gen: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
        x = self.x_raw[idx]
        if _dequantized(self.spec):
            x = x + torch.rand(x.shape, generator=gen, dtype=x.dtype)
        elif self.jitter > 0:
            x = x + self.jitter * torch.randn(x.shape, generator=gen, dtype=x.dtype)
        xe = torch.stack([_encode_torch(e, x[:, i]) for i, e in enumerate(self.out_enc)], 1)
        return self.c[idx], xe.to(torch.float32)


# --------------------------------------------------------------------------------------
# Training one model
# --------------------------------------------------------------------------------------
def _lr_at(cfg: TrainConfig, step: int, progress: float) -> float:
    warm = min(1.0, (step + 1) / cfg.lr_warmup_steps)
    cos = 0.5 * (1.0 + math.cos(math.pi * min(1.0, progress)))
    return warm * (cfg.lr_final + (cfg.lr - cfg.lr_final) * cos)


@torch.no_grad()
def evaluate_cvae(model: CVAE, batches: _Batches, idx: torch.Tensor, seed: int) -> dict:
    """ELBO terms on the walks idx (β = 1, no free bits): NLL, KL and KL per latent dim."""
    gen = torch.Generator().manual_seed(seed)
    nll_sum, kl_sum, n = 0.0, torch.zeros(model.spec.latent_dim, dtype=torch.float64), 0
    for start in range(0, idx.shape[0], 65536):
        i = idx[start:start + 65536]
        c, x = batches.get(i, gen)
        noise = torch.randn(i.shape[0], model.spec.latent_dim, generator=gen)
        xm, xl, zm, zl = model(c, x, noise)
        nll_sum += float(gaussian_nll(x, xm, xl).double().sum())
        kl_sum += kl_per_dim(zm, zl).double().sum(dim=0)
        n += i.shape[0]
    kl = (kl_sum / n).tolist()
    return {"nll": nll_sum / n, "kl": float(sum(kl)), "kl_per_latent_dim": kl,
            "latent_dims_active": int(sum(k > ACTIVE_LATENT_NATS for k in kl))}


def _walks_for(spec: ModelSpec, data: TrainingData) -> TrainingData:
    """The walks a model trains on: N >= 2 (EventGen: and a representative event k >= 2,
    X != 0), at least 2 of them, whose conditions vary."""
    rows = data.N >= 2
    if spec.name == "EventGen":
        rows &= np.any(data.X != 0, axis=1)
    sub = data.subset(rows)
    if len(sub) < 2:
        raise ValueError(f"{data.path}: fewer than 2 walks to train {spec.name} on (it needs "
                         f"N >= 2{' and X != 0' if spec.name == 'EventGen' else ''})")
    check_conditions_vary(sub, spec.conditions, spec.name)  # as fit_encodings will
    return sub


def _torch_seed(seed: int, factor: int, spec: ModelSpec) -> int:
    """A model's torch seed from the run's: below 2^63 (torch's limit; a seed past about
    10^14 overflowed it), the same as before for smaller seeds."""
    return (seed * factor + _seed_index(spec)) % 2**63


def train_cvae(spec: ModelSpec, data: TrainingData, cfg: TrainConfig, seed: int,
               time_budget_s: float | None = None, progress: bool = True):
    """Train one CVAE on the walks with N ≥ 2 of data (EventGen: and a representative event
    k ≥ 2, i.e. X ≠ 0; the first event is sampled exactly, docs/model-format.md).
    Returns (model, encodings, report)."""
    data = _walks_for(spec, data)
    rng = np.random.default_rng([seed, _seed_index(spec)])
    torch.manual_seed(_torch_seed(seed, 7919, spec))
    enc = fit_encodings(spec, data, rng, cfg.encodings)
    batches = _Batches(spec, data, enc, cfg)
    gen = torch.Generator().manual_seed(_torch_seed(seed, 104729, spec))
    perm = torch.randperm(len(batches), generator=gen)
    n_val = min(cfg.max_val, max(1, int(round(cfg.val_fraction * len(batches)))))
    if len(batches) - n_val < 1:
        n_val = 0
    val_idx, train_idx = perm[:n_val], perm[n_val:]
    n_train = train_idx.shape[0]
    batch = min(cfg.batch_size, n_train)
    steps_per_epoch = -(-n_train // batch)
    total_steps = max(1, cfg.epochs * steps_per_epoch)

    model = CVAE(spec)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    bar = Progress(f"{spec.name:<9}", progress)
    t0 = time.monotonic()
    step, progress_frac, done = 0, 0.0, False
    epoch_losses = []
    epochs_done = 0.0
    for epoch in range(cfg.epochs):
        order = train_idx[torch.randperm(n_train, generator=gen)]
        loss_sum, loss_n = 0.0, 0
        for start in range(0, n_train, batch):
            elapsed = time.monotonic() - t0
            progress_frac = step / total_steps
            if time_budget_s:
                progress_frac = max(progress_frac, elapsed / time_budget_s)
            if progress_frac >= 1.0:
                done = True
                break
            for group in opt.param_groups:
                group["lr"] = _lr_at(cfg, step, progress_frac)
            beta_kl = min(1.0, progress_frac / cfg.kl_warmup) if cfg.kl_warmup > 0 else 1.0
            idx = order[start:start + batch]
            c, x = batches.get(idx, gen)
            noise = torch.randn(idx.shape[0], spec.latent_dim, generator=gen)
            xm, xl, zm, zl = model(c, x, noise)
            nll = gaussian_nll(x, xm, xl).mean()
            kl = kl_per_dim(zm, zl).mean(dim=0)
            loss = nll + beta_kl * torch.clamp(kl, min=cfg.free_bits).sum()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            if cfg.grad_clip:
                torch.nn.utils.clip_grad_norm_(model.parameters(), cfg.grad_clip)
            opt.step()
            elbo = float(nll.detach()) + float(kl.detach().sum())
            if not math.isfinite(elbo):
                raise FloatingPointError(f"{spec.name}: the loss became {elbo} at step {step}")
            loss_sum += elbo * idx.shape[0]
            loss_n += idx.shape[0]
            step += 1
            epochs_done = step / steps_per_epoch
            bar.update(max(progress_frac, step / total_steps),
                       f"epoch {epoch + 1}/{cfg.epochs} loss {loss_sum / loss_n:8.4f}")
        if loss_n:
            epoch_losses.append(loss_sum / loss_n)
        if done:
            break
    bar.update(1.0, f"loss {epoch_losses[-1] if epoch_losses else float('nan'):8.4f}")
    bar.close()
    seconds = time.monotonic() - t0
    model.eval()
    val = evaluate_cvae(model, batches, val_idx if n_val else train_idx[:50_000],
                        (seed + 1) % 2**63)  # torch takes seeds below 2^63
    report = {
        "train_loss_per_epoch": epoch_losses,
        "val_nll": val["nll"],
        "val_kl": val["kl"],
        "val_loss": val["nll"] + val["kl"],
        "kl_per_latent_dim": val["kl_per_latent_dim"],
        "latent_dims_active": val["latent_dims_active"],
        "active_threshold_nats": ACTIVE_LATENT_NATS,
        "epochs_completed": epochs_done,
        "steps": step,
        "stopped_by_time_limit": bool(done and step < total_steps),
        "seconds": seconds,
        "samples_per_second": step * batch / seconds if seconds > 0 else float("nan"),
        "n_train": int(n_train),
        "n_val": int(n_val),
    }
    return model, enc, report


# --------------------------------------------------------------------------------------
# All three
# --------------------------------------------------------------------------------------
def _ranges(data: TrainingData) -> dict:
    """Training ranges of σ, g, φ: the data file's meta ranges (those its conditions were drawn
    from; checked by data.validate_meta) when they cover the data, else the data's min and
    max."""
    out = {}
    for k in ("sigma", "g", "phi"):
        v = getattr(data, k)
        lo, hi = float(v.min()), float(v.max())
        r = data.meta.get(f"{k}_range")
        if r is None and k != "phi" and f"{k}_max" in data.meta:  # datagen: sigma_max, g_max
            m = data.meta[f"{k}_max"]
            r = [0.0, m] if k == "sigma" else [-m, m]
        if (isinstance(r, list) and len(r) == 2 and all(isinstance(x, (int, float)) for x in r)
                and r[0] <= lo and hi <= r[1]):
            lo, hi = float(r[0]), float(r[1])
        out[k] = [lo, hi]
    return out


def train(data_path, out_dir, epochs: int | None = None, seed: int = 0,
          max_minutes: float | None = None, progress: bool = True,
          config: TrainConfig | None = None, models=("LengthGen", "PathGen", "EventGen")) -> dict:
    """Train LengthGen, PathGen and EventGen on a training-data file and export them.

    Parameters
    ----------
    data_path : path of a training-data `.npz` (`sssphere.learn.data`).
    out_dir : directory for ``<name>.json``, ``<name>.onnx`` and ``cvae_checkpoint.pt``
        (created if missing). The files are moved in together when all are written; a run
        that fails or is interrupted leaves the directory as it was.
    epochs : passes over the data per model (default: ``TrainConfig.epochs``).
    seed : seeds every random choice (initialisation, batches, noise).
    max_minutes : wall-clock limit for all models together (split by `TIME_SHARES`); the
        learning-rate and KL schedules then follow the clock.
    progress : progress bars and the summary on stderr.
    config : all other hyperparameters.
    models : which of the three to train (all by default).

    Returns
    -------
    dict: per model name its report (losses, latent usage, time), and ``"files"``.
    """
    # torch-side, lazily
    from sssphere.learn.export import save_checkpoint, staged_output, write_model

    cfg = TrainConfig(**asdict(config)) if config is not None else TrainConfig()
    if epochs is not None:  # checked as TrainConfig checks it (1.5 trained 1 epoch)
        cfg = TrainConfig(**{**asdict(cfg), "epochs": epochs})
    if max_minutes is not None and not max_minutes > 0:
        raise ValueError(f"max_minutes must be > 0, got {max_minutes}")
    unknown = [m for m in models if m not in TIME_SHARES]
    if unknown:
        raise ValueError(f"unknown model(s) {unknown} (allowed: {list(TIME_SHARES)})")
    out = Path(out_dir)
    data = load_training_data(data_path)  # says what is wrong with it, before any directory
    # A single medium cannot be learned from: told now, not as a nan loss minutes later;
    # nor data without the walks a model needs (no EventGen without events k >= 2), which
    # was found after the models before it had trained.
    check_conditions_vary(data, sorted({c for s in SPECS if s.name in models
                                        for c in s.conditions} - {"N"}))
    for spec in SPECS:
        if spec.name in models:
            _walks_for(spec, data)
    names = [f"{s.file_stem}.{ext}" for s in SPECS if s.name in models
             for ext in ("json", "onnx")] + ["cvae_checkpoint.pt"]

    threads_before = torch.get_num_threads()
    det_before = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(cfg.threads)
    torch.use_deterministic_algorithms(True)
    t_start = time.monotonic()
    results, trained = {}, {}
    # All files go to a staging directory and into `out` together at the end: an
    # interrupted or failed run leaves the models there as they were (not a mixed set).
    # staged_output checks the output directory first, before minutes of training.
    try:
        with staged_output(out, names) as stage, _keeping_finished(out, models, trained):
            share_sum = sum(TIME_SHARES[m] for m in models)
            for spec in SPECS:
                if spec.name not in models:
                    continue
                budget = None
                if max_minutes is not None:
                    budget = 60.0 * max_minutes * TIME_SHARES[spec.name] / share_sum
                model, enc, report = train_cvae(spec, data, cfg, seed, budget, progress)
                if report["epochs_completed"] == 0:  # untrained weights, written as a model
                    raise ValueError(
                        f"max_minutes {max_minutes}: {spec.name}'s share of it ({budget:.3g} s)"
                        " ended before its first training step; nothing was trained")
                training = {
                    **_ranges(data),
                    "data_file": Path(data.path).name,
                    "data_meta": data.meta,
                    "n_walks": len(data),
                    "n_samples": report["n_train"],
                    "n_validation": report["n_val"],
                    "epochs": cfg.epochs,
                    "epochs_completed": report["epochs_completed"],
                    "seed": seed,
                    **{k: v for k, v in asdict(cfg).items() if k not in ("epochs",)},
                    "loss": "negative ELBO: Gaussian NLL of the encoded outputs + "
                            "beta * sum_j max(free_bits, batch-mean KL_j)",
                    "rows": ("N >= 2 and X != 0 (events k >= 2)" if spec.name == "EventGen"
                             else "N >= 2"),
                    "noise": ("targets N + U[0,1)" if spec.name == "LengthGen" else
                              f"targets + N(0, {cfg.event_jitter}^2)"
                              if spec.name == "EventGen" and cfg.event_jitter > 0 else "none"),
                    "torch_version": torch.__version__,
                }
                metrics = {k: report[k] for k in (
                    "val_nll", "val_kl", "val_loss", "kl_per_latent_dim", "latent_dims_active",
                    "active_threshold_nats")}
                write_model(stage, spec, model, enc, training, metrics)
                trained[spec.name] = (model, enc, training, metrics)
                results[spec.name] = report
            save_checkpoint(stage / "cvae_checkpoint.pt", trained)
    finally:
        torch.set_num_threads(threads_before)
        torch.use_deterministic_algorithms(det_before)
    total = time.monotonic() - t_start
    results["files"] = [str(out / n) for n in names]
    results["seconds"] = total
    if progress:
        print(format_summary(results), file=sys.stderr)
    return results


class InterruptedWithFinishedModels(KeyboardInterrupt):
    """Ctrl-C or SIGTERM after some models had finished: the output directory is unchanged,
    and the finished models are in ``partial`` (``finished``; ``missing`` are the rest)."""

    def __init__(self, partial: Path, finished: list, missing: list):
        super().__init__()
        self.partial, self.finished, self.missing = partial, finished, missing


@contextlib.contextmanager
def _keeping_finished(out: Path, models, trained: dict):
    """On an interrupt, the models `trained` so far go to OUT.partial (their files together,
    as staged_output moves them), so that minutes of training are not lost: ``sssphere train
    DATA -o OUT.partial --models REST`` completes that set. The output directory itself
    stays as it was (never a mix of old and new models)."""
    from sssphere.learn.export import save_checkpoint, staged_output, write_model

    try:
        yield
    except KeyboardInterrupt as e:
        finished = [s for s in SPECS if s.name in trained]
        missing = [m for m in models if m not in trained]
        if not finished or not missing or isinstance(e, InterruptedWithFinishedModels):
            raise
        out = out.resolve()  # "-o ." has no name to add ".partial" to
        partial = out.with_name(out.name + ".partial")
        names = [f"{s.file_stem}.{ext}" for s in finished for ext in ("json", "onnx")]
        with staged_output(partial, names + ["cvae_checkpoint.pt"]) as stage:
            for spec in finished:
                write_model(stage, spec, *trained[spec.name])
            save_checkpoint(stage / "cvae_checkpoint.pt", trained)
        raise InterruptedWithFinishedModels(partial, [s.name for s in finished],
                                            missing) from None


def format_summary(results: dict) -> str:
    """A few lines: per model the losses, latent usage and time."""
    lines = ["model      val NLL   val KL  latent KL per dim (nats)              used  epochs   time"
             "   samples/s"]
    for name in TIME_SHARES:
        r = results.get(name)
        if r is None:
            continue
        kl = " ".join(f"{k:5.2f}" for k in r["kl_per_latent_dim"])
        lines.append(f"{name:<9} {r['val_nll']:8.4f} {r['val_kl']:8.4f}  {kl:<36} "
                     f"{r['latent_dims_active']:>4}  {r['epochs_completed']:6.2f} "
                     f"{r['seconds']:6.1f}s {r['samples_per_second']:10.0f}"
                     + ("  (time limit)" if r["stopped_by_time_limit"] else ""))
    names = ", ".join(Path(f).name for f in results["files"])
    lines.append(f"total {results['seconds']:.1f}s; wrote {names}")
    return "\n".join(lines)
