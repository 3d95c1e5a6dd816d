#!/usr/bin/env python3
"""Write the real-CAD scenes of docs/benchmarks.md "The bounded tick" (issue 44): robot link
meshes as exported, from the PyPI package rtb-data 2.0.0 (not a project dependency; the
meshes are not part of this repository).

Usage:
    python3 benches/cad/rtb_scenes.py target/rtb

downloads the rtb-data 2.0.0 wheel with pip (`pip download --no-deps`), unpacks its
meshes into target/rtb/rtbdata/meshes, and writes target/rtb/{link6-wall,orion-link3-wall,
cad-obstacles}.toml. Each moving part is placed with its bounding box's centre on the
reference point (the offsets below were computed from the STL files); each must pass a
150 x 120 mm hole in a 20 mm wall of four boxes, starting yawed 90 degrees (too long across
to fit) and ending at yaw 0. Then, e.g.:
    target/release/tick-budget --scene target/rtb/link6-wall.toml --newcomer --cpu-time --seconds 60
"""
import subprocess
import sys
import zipfile
from pathlib import Path

WALL = """
[[obstacles]] # above the hole
shape = "box"
half_extents_m = [0.01, 0.35, 0.145]
position_m = [0.0, 0.0, 0.205]

[[obstacles]] # below the hole
shape = "box"
half_extents_m = [0.01, 0.35, 0.145]
position_m = [0.0, 0.0, -0.205]

[[obstacles]] # +y side
shape = "box"
half_extents_m = [0.01, 0.1375, 0.06]
position_m = [0.0, 0.2125, 0.0]

[[obstacles]] # -y side
shape = "box"
half_extents_m = [0.01, 0.1375, 0.06]
position_m = [0.0, -0.2125, 0.0]
"""

HEAD = """name = "{name}"

[bounds]
min_m = [-0.30, -0.20, -0.20]
max_m = [0.30, 0.20, 0.20]

[start]
position_m = [-0.20, 0.0, 0.0]
rpy_rad = [0.0, 0.0, 1.5707963267948966]

[goal]
position_m = [0.20, 0.0, 0.0]
"""

LINK6 = """
[[moving_object]] # Panda link 6: 21 620 triangles, open, 42 components, metres
shape = "mesh"
file = "rtbdata/meshes/FRANKA-EMIKA/Panda/link6_original.stl"
position_m = [-0.04205, -0.01525, -0.00615]
"""

SCENES = {
    "link6-wall": WALL + LINK6,
    "orion-link3-wall": WALL
    + """
[[moving_object]] # RAWR Orion5 link 3: 70 226 triangles, closed, millimetres
shape = "mesh"
file = "rtbdata/meshes/RAWR/Orion5/link3.stl"
scale = 0.001
position_m = [0.07084, -0.02075, 0.0]
""",
    "cad-obstacles": WALL
    + """
[[obstacles]] # Panda link 0: 20 483 triangles, open
shape = "mesh"
file = "rtbdata/meshes/FRANKA-EMIKA/Panda/link0_original.stl"
position_m = [0.19127, 0.2, -0.07]

[[obstacles]] # RAWR Orion5 link 3: 70 226 triangles, closed, millimetres
shape = "mesh"
file = "rtbdata/meshes/RAWR/Orion5/link3.stl"
scale = 0.001
position_m = [0.22084, -0.15075, 0.0]
"""
    + LINK6,
}


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    wheel = out / "rtb_data-2.0.0-py3-none-any.whl"
    if not wheel.exists():
        subprocess.run(
            [sys.executable, "-m", "pip", "download", "--no-deps", "rtb-data==2.0.0", "-d", str(out)],
            check=True,
        )
    with zipfile.ZipFile(wheel) as z:
        members = [m for m in z.namelist() if m.startswith("rtbdata/meshes/") and m.endswith(".stl")]
        z.extractall(out, members)
    for name, body in SCENES.items():
        (out / f"{name}.toml").write_text(HEAD.format(name=name) + body)
        print(out / f"{name}.toml")
    return 0


if __name__ == "__main__":
    sys.exit(main())
