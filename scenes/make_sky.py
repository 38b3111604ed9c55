"""Writes an equirectangular sky (an environment map, docs/scene-format.md) to an EXR file,
from a small analytic model, so that no sky needs downloading: a blue sky brightening
towards the horizon and around the sun, a small bright sun disc, and a dim ground below
the horizon. Not a physical atmosphere (no Preetham or Hosek-Wilkie fit): a plausible,
smooth daylight with one strong direction, which is what the renderer's importance
sampling has to handle.

The map follows Mitsuba 3's envmap convention: +y up, row 0 the zenith, pixel (x, y) the
direction of travel at u = (x + 1/2) / W, v = y / (H - 1), theta = pi v, phi = 2 pi u,
direction (sin theta sin phi, cos theta, -sin theta cos phi).

    python3 scenes/make_sky.py scenes/sky.exr --sun-elevation 35 --sun-azimuth 120

With --no-sun the disc is left out (its glow stays): the sun is then a directional light of
the scene, travelling along -(cos e sin a, sin e, -cos e cos a) for elevation e and azimuth a,
as in scenes/showcase.json (whose sky.exr is `--width 256 --no-sun --sun-elevation 35
--sun-azimuth 250`).
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def sky(width: int, sun_elevation: float, sun_azimuth: float,
        sun_radiance: float | None = 2.0e4, sun_radius_deg: float = 0.8) -> np.ndarray:
    """The map, (width / 2, width, 3) float32 linear radiance. Angles in degrees; the sun's
    azimuth is phi = 2 pi u of the convention above (0: towards -z). sun_radiance None: no
    disc."""
    height = width // 2
    x = np.arange(width)
    y = np.arange(height)
    theta = math.pi * y / (height - 1)
    phi = 2 * math.pi * (x + 0.5) / width
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = np.stack([st * np.sin(phi)[None, :], np.broadcast_to(ct, (height, width)),
                  -st * np.cos(phi)[None, :]], axis=-1)
    el, az = math.radians(sun_elevation), math.radians(sun_azimuth)
    sun = np.array([math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az)])
    cos_sun = np.clip(d @ sun, -1.0, 1.0)
    up = np.clip(d[..., 1], 0.0, 1.0)
    # Sky: zenith blue to a paler horizon, plus forward scattering around the sun.
    zenith, horizon = np.array([0.12, 0.25, 0.65]), np.array([0.55, 0.65, 0.80])
    t = (1.0 - up)[..., None] ** 3
    base = zenith * (1 - t) + horizon * t
    glow = 0.6 * np.exp(-np.arccos(cos_sun) * 3.0)[..., None] * np.array([1.0, 0.9, 0.7])
    img = base + glow
    # Ground: a dim, warm grey, darker straight down; a soft horizon line.
    ground = np.array([0.18, 0.16, 0.14]) * (0.6 + 0.4 * (1 + d[..., 1:2]))
    w = np.clip(d[..., 1:2] / 0.02 + 0.5, 0.0, 1.0)
    img = img * w + ground * (1 - w)
    # The sun disc.
    if sun_radiance is not None:
        disc = cos_sun > math.cos(math.radians(sun_radius_deg))
        img[disc] = sun_radiance * np.array([1.0, 0.95, 0.85])
    return img.astype(np.float32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("output", help="the EXR file to write")
    ap.add_argument("--width", type=int, default=512, help="pixels (height = width / 2)")
    ap.add_argument("--sun-elevation", type=float, default=35.0, help="degrees above the horizon")
    ap.add_argument("--sun-azimuth", type=float, default=120.0, help="degrees, phi = 2 pi u")
    ap.add_argument("--no-sun", action="store_true",
                    help="leave out the sun disc (light the scene with a directional light)")
    a = ap.parse_args()
    if a.width < 8 or a.width % 2:
        ap.error("--width must be an even number >= 8")
    import sssphere

    sssphere.write_image(a.output, sky(a.width, a.sun_elevation, a.sun_azimuth,
                                       sun_radiance=None if a.no_sun else 2.0e4))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
