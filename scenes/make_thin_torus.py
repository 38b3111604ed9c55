"""Writes scenes/meshes/thin_torus.obj: a closed torus whose tube is thin (radius 0.035
against a ring radius of 0.4), the "thin features" case where spheres inside the medium
stay small. Run: python3 scenes/make_thin_torus.py"""

import argparse
import math
from pathlib import Path

R, r = 0.4, 0.035  # ring and tube radii (scene units)
NU, NV = 128, 24  # segments around the ring and around the tube


def main() -> None:
    default = Path(__file__).parent / "meshes" / "thin_torus.obj"
    parser = argparse.ArgumentParser(description=__doc__.split("Run:")[0].strip())
    parser.add_argument("-o", "--output", type=Path, default=default,
                        help=f"the OBJ file to write (default: {default})")
    out = parser.parse_args().output
    lines = ["# thin torus: R = 0.4, r = 0.035 (written by scenes/make_thin_torus.py)"]
    for i in range(NU):
        u = 2 * math.pi * i / NU
        for j in range(NV):
            v = 2 * math.pi * j / NV
            x = (R + r * math.cos(v)) * math.cos(u)
            z = (R + r * math.cos(v)) * math.sin(u)
            y = r * math.sin(v)
            lines.append(f"v {x:.6f} {y:.6f} {z:.6f}")
    for i in range(NU):
        for j in range(NV):
            a = i * NV + j
            b = ((i + 1) % NU) * NV + j
            c = ((i + 1) % NU) * NV + (j + 1) % NV
            d = i * NV + (j + 1) % NV
            lines.append(f"f {a + 1} {b + 1} {c + 1} {d + 1}")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
