"""`sssphere info`: a scene in brief, with what transport theory expects a render of it to
cost (docs/info.md says where each figure comes from and how far to trust it)."""

from __future__ import annotations

from typing import Any

import numpy as np

from sssphere import rendering
from sssphere.scene import Scene

# Volume samples for the sphere-tracing estimate: its relative noise is about
# 1/sqrt(samples * deep fraction), well under the estimate's model error.
_VOLUME_SAMPLES = 200_000


def _medium_estimates(scene: Scene, i: int, shape: dict, tau: float,
                      clearance: float = 0.0) -> dict:
    """Transport-theory figures for a path that enters medium shape i (docs/info.md).

    pt: a path that enters a body of volume V and surface S under uniform, isotropic
    illumination travels 4V/S inside on average, whatever the scattering, if nothing is
    absorbed (the invariance property of the mean path length: Blanco and Fournier 2003);
    4 eta^2 V/S behind a boundary of relative index eta (the radiance inside is eta^2 times
    the outside's at equilibrium). Collisions come at rate sigma_t along it, so it
    scatters sigma_t times that often. Absorption shortens the paths by the factor that
    diffusion theory gives the mean fluence of a sphere of the same V/S (radius R = 3V/S)
    under uniform illumination: f = 3 (x coth x - 1) / x^2 with x = kappa R,
    kappa = sqrt(3 sigma_a sigma_t') (1 without absorption).

    st: the collision density of such paths is uniform in the body (exact without
    absorption), so a fraction f of the events falls where sigma_t r >= tau and sphere
    steps replace them; a step from the centre of a sphere of radius r stands for
    (sigma_t r)(sigma_t' r)/2 events (the diffusion exit time from a sphere). Steps per
    path: the pt events times the mean of [deep] / n(r) over the volume. Where the medium's
    steps keep clear of point lights and the boundary (``clearance`` c mean free paths:
    st's default NEE in an index-matched medium under a point or directional light), a
    step needs sigma_t r >= tau + c and covers the radius r - c / sigma_t. Chromatic
    media: each channel a third of the paths, deep where both the switch extinction
    (spectral_switch_extinction: the smallest, or the largest over SPECTRAL_SWITCH_RATIO)
    and the channel's own reach tau + c.
    """
    sigma_t = np.asarray(shape["sigma_t"], np.float64)
    albedo = np.asarray(shape["albedo"], np.float64)
    g = float(shape["g"])
    sigma_a = sigma_t * (1.0 - albedo)
    sigma_tr = sigma_t * albedo * (1.0 - g) + sigma_a  # reduced extinction sigma_t'
    mean_length = 4.0 * shape["ior"] ** 2 * shape["volume"] / shape["area"]
    x = np.sqrt(3.0 * sigma_a * sigma_tr) * 3.0 * shape["volume"] / shape["area"]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(x > 1e-4, 3.0 * (x / np.tanh(np.maximum(x, 1e-4)) - 1.0) / x ** 2, 1.0)
    length = mean_length * f
    events_c = sigma_t * length
    events = float(np.mean(events_c))  # hero channels are drawn uniformly

    vertices, _ = scene.shape_mesh(i)
    lo, hi = vertices.min(0).astype(np.float64), vertices.max(0).astype(np.float64)
    rng = np.random.default_rng(0)
    points = lo + rng.random((_VOLUME_SAMPLES, 3)) * (hi - lo)
    inside = scene.grid_inside(i, points)
    r = scene.distance_lower_bound(i, points[inside]).astype(np.float64)
    sigma_switch = max(float(sigma_t.min()),
                       float(sigma_t.max()) / rendering._core.SPECTRAL_SWITCH_RATIO)
    deep_fraction, st_events, st_steps = 0.0, 0.0, 0.0
    for c in range(3):  # one channel per path from its first step on, each a third
        sigma_c = float(sigma_t[c])
        deep = (sigma_switch * r >= tau + clearance) & (sigma_c * r >= tau + clearance)
        r_step = r[deep] - (clearance / sigma_c if sigma_c > 0 else 0.0)  # none deep at 0
        n = 0.5 * r_step ** 2 * sigma_c * sigma_tr[c]  # events per step
        f = float(deep.mean()) if r.size else 0.0
        deep_fraction += f / 3.0
        st_events += events_c[c] * (1.0 - f) / 3.0
        st_steps += events_c[c] * float(np.sum(1.0 / np.maximum(n, 1.0)) / max(r.size, 1)) / 3.0
    return {
        "mean_free_path": _lengths(sigma_t),
        "transport_mean_free_path": _lengths(sigma_tr),
        "multiple_scattering_albedo": [
            rendering._core.multiple_scattering_albedo(float(a)) for a in
            albedo * (1.0 - g) / np.maximum(albedo * (1.0 - g) + 1.0 - albedo, 1e-30)],
        "mean_path_length": mean_length,
        "path_length_with_absorption": float(np.mean(length)),
        "pt_events": events,
        "deep_fraction": deep_fraction,
        "st_events": float(st_events),
        "st_steps": float(st_steps),
    }


def scene_info(scene: Scene) -> dict[str, Any]:
    """The scene in brief: image, integrator and render settings, each shape (triangles,
    distance grid, medium or surface, the share of camera rays that hit it first) and
    the lights; for each medium, the expected scattering events per path that enters it
    with ``pt`` and the events and sphere steps with ``st`` (see _medium_estimates), and
    those per camera path (weighted by the shares)."""
    options = rendering._core.resolve_render_options(scene, str(rendering.DEFAULT_MODELS))
    first = rendering.first_hit_aovs(scene, seed=0, samples=1)["shape"]
    tau = float(options["sphere_threshold"])
    lights = scene.lights.to_python() if "lights" in scene.to_dict() else []
    delta_lights = any(light.get("type") in ("point", "directional") for light in lights)
    try:  # which media "st" steps in: deep enough, and its models trained for them
        check = rendering._core.check_sphere_steps(scene, str(rendering.DEFAULT_MODELS))
        st_error = None
    except ValueError as e:  # no models, a threshold below their range: st cannot render
        check, st_error = {"steps": [True] * scene.num_shapes, "warnings": []}, str(e)
    shapes = []
    per_path = {"pt_events": 0.0, "st_events": 0.0, "st_steps": 0.0}
    for i in range(scene.num_shapes):
        shape = dict(scene.shape_info(i))
        shape["coverage"] = float(np.mean(first == i))
        if shape["kind"] == "medium":
            # SphereTracing::clearance: steps keep clear where their events sample such lights
            cleared = (delta_lights and bool(options["nee"]) and options["step_nee"] == "hits"
                       and shape["boundary"] == "index_matched")
            shape.update(_medium_estimates(
                scene, i, shape, tau,
                float(rendering._core.DELTA_LIGHT_CLEARANCE) if cleared else 0.0))
            shape["st_untrained"] = any(f"shapes[{i}] " in w for w in check["warnings"])
            if not check["steps"][i]:  # "st" renders it as "pt" does
                shape.update(deep_fraction=0.0, st_events=shape["pt_events"], st_steps=0.0)
            for key in per_path:
                per_path[key] += shape["coverage"] * shape[key]
        shapes.append(shape)
    return {"source": scene.source, "width": scene.width, "height": scene.height,
            "options": options, "shapes": shapes,
            "lights": [light.get("type", "?") for light in lights],
            "per_camera_path": per_path, "st_warnings": check["warnings"],
            "st_error": st_error}


def _lengths(sigma: np.ndarray) -> list:
    """1 / sigma per channel; None (JSON null, shown as inf) where sigma is 0: JSON has no
    infinity."""
    return [1.0 / float(x) if x > 0 else None for x in sigma]


def _vec(values, digits: int = 4) -> str:
    values = [float("inf") if v is None else v for v in values]
    if all(v == values[0] for v in values):
        return f"{values[0]:.{digits}g}"
    return "[" + ", ".join(f"{v:.{digits}g}" for v in values) + "]"


def _count(x: float) -> str:
    return f"{x:,.0f}" if x >= 100 else f"{x:.3g}"


def format_info(info: dict[str, Any]) -> str:
    """scene_info as the text `sssphere info` prints."""
    o = info["options"]
    lines = [f"{info['source']}: {info['width']}x{info['height']} pixels, integrator "
             f"{o['integrator']}, {o['spp']} spp, seed {o['seed']}"
             + (f", sphere threshold {o['sphere_threshold']:g}" if o["integrator"] == "st"
                else "")]
    for s in info["shapes"]:
        head = (f"shape '{s['name']}': {s['kind']}, {s['triangles']:,} triangles, "
                f"{100 * s['coverage']:.1f}% of the image")
        if s["kind"] == "surface":
            lines.append(f"{head}; {s['surface']} surface, colour {_vec(s['color'], 3)}")
            continue
        lines += [
            f"{head}; distance grid {s['grid_resolution']} cells along its longest side",
            f"  medium: sigma_t {_vec(s['sigma_t'])} per unit (mean free path "
            f"{_vec(s['mean_free_path'], 3)}), albedo {_vec(s['albedo'])}, {s['phase']} "
            f"g {s['g']:g}; transport mean free path {_vec(s['transport_mean_free_path'], 3)}",
            f"  looks like (multiple-scattering albedo) {_vec(s['multiple_scattering_albedo'], 3)}"
            f"; boundary {s['boundary']}",
            f"  a path that enters it: mean length 4 ior^2 V/S = {s['mean_path_length']:.4g}"
            + (f" ({s['path_length_with_absorption']:.4g} with absorption)"
               if s["path_length_with_absorption"] < 0.999 * s["mean_path_length"] else ""),
            f"    pt: ~{_count(s['pt_events'])} scattering events",
            f"    st: ~{_count(s['st_events'])} events + ~{_count(s['st_steps'])} sphere steps "
            + ("(none: the sphere-step models were not trained for this medium)"
               if s["st_untrained"] else
               f"({100 * s['deep_fraction']:.0f}% of the volume is deep enough to step)"),
        ]
        if s["surfaces_meeting"]:
            names = ", ".join(f"'{info['shapes'][j]['name']}'" for j in s["surfaces_meeting"])
            lines.append(f"  meets the opaque surface(s) {names}: resting on one as across a "
                         "gap too thin to see, one through it in optical contact")
    if info.get("st_error"):
        lines.append(f"st cannot render this scene: {info['st_error']}")
    lines.append("lights: " + (", ".join(info["lights"]) if info["lights"] else "none"))
    p = info["per_camera_path"]
    lines.append(f"expected per camera path (camera rays that hit a medium directly): "
                 f"pt ~{_count(p['pt_events'])} events; st ~{_count(p['st_events'])} events + "
                 f"~{_count(p['st_steps'])} sphere steps")
    lines.append("(transport-theory estimates for light entering from all sides, "
                 "uniform collisions: docs/info.md says how far to trust them)")
    return "\n".join(lines)


__all__ = ["scene_info", "format_info"]
