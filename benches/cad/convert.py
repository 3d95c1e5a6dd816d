#!/usr/bin/env python3
"""Convert OMPL.app's rigid-body CAD puzzles (COLLADA meshes + .cfg problems) to our TOML
scenes with OBJ meshes, for measurement only: the meshes are not part of this repository
(OMPL.app is under the Rice University software licence; fetch it yourself).

Setup (not a project dependency):
    git clone --depth 1 https://github.com/ompl/omplapp target/omplapp
    python3 -m venv target/cad-venv && target/cad-venv/bin/pip install pycollada==0.9.3 coal==3.0.3
Usage:
    target/cad-venv/bin/python benches/cad/convert.py target/omplapp/resources/3D target/cad

writes target/cad/<puzzle>.toml, target/cad/meshes/<puzzle>-{object,env}.obj, and checks
the conversion with coal (an independent checker): start and goal must be free, and so
must every waypoint of OMPL.app's stored solution path (`<puzzle>.path`) where there is
one. Exit code 1 if any is not.

How OMPL.app reads these files, reproduced here (src/omplapp/geometry in OMPL.app):
- assimp's COLLADA importer turns a Z_UP file into assimp's Y-up frame by a rotation at
  the root, (x, y, z) -> (x, z, -y); the .cfg start, goal and bounds are in that frame,
  so both meshes are written in it;
- node transforms are applied (the <matrix> of every node on the way to the geometry);
- the robot's reference point is the mean of its vertices after assimp's
  JoinIdenticalVertices, which merges corners equal in position, normal and texture
  coordinate within one mesh: the robot is shifted so that mean is its origin.
Units: file units times the puzzle's `scale` (metres per unit, below), chosen so each
scene spans a few tenths of a metre like the built-in scenes, since our planner's step
(0.05) and edge resolution (0.005) are absolute.
"""
import argparse
import math
import os
import sys

import collada
import numpy as np

# name -> (cfg file, metres per file unit)
PUZZLES = {
    "alpha-1.5": ("alpha-1.5.cfg", 0.001),
    "twistycool": ("Twistycool.cfg", 0.001),
    "bugtrap": ("bugtrap.cfg", 0.01),
}

# assimp's Z_UP -> Y_UP root rotation: x' = x, y' = z, z' = -y.
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def read_cfg(path):
    values = {}
    with open(path) as f:
        section = None
        for line in f:
            line = line.strip()
            if line.startswith("["):
                section = line.strip("[]")
            elif "=" in line and section == "problem":
                k, v = line.split("=", 1)
                values[k.strip()] = v.strip()
    return values


def triangles(dae_path):
    """All triangles in assimp's frame, (n, 3, 3), and the corners assimp would keep
    after JoinIdenticalVertices (positions, for the robot's centre)."""
    dae = collada.Collada(dae_path)
    up = dae.assetInfo.upaxis if dae.assetInfo is not None else "Y_UP"
    root = Z_UP_TO_Y_UP if up == "Z_UP" else np.eye(3)
    if up not in ("Z_UP", "Y_UP"):
        sys.exit(f"{dae_path}: up axis {up} is not handled (only Z_UP and Y_UP)")
    tris, kept = [], []
    for geom in dae.scene.objects("geometry"):
        for prim in geom.primitives():
            if isinstance(prim, (collada.polylist.BoundPolylist, collada.polygons.BoundPolygons)):
                prim = prim.triangleset()
            if not isinstance(prim, collada.triangleset.BoundTriangleSet):
                continue  # lines and points carry no volume
            corners = prim.vertex[prim.vertex_index]  # (n, 3, 3), node transforms applied
            tris.append(corners @ root.T)
            rows = [corners.reshape(-1, 3)]
            if prim.normal_index is not None and len(prim.normal) > 0:
                rows.append(prim.normal[prim.normal_index].reshape(-1, 3))
            for ts, ti in zip(prim.texcoordset, prim.texcoord_indexset):
                rows.append(ts[ti].reshape(-1, ts.shape[1]))
            unique = np.unique(np.hstack(rows), axis=0)
            kept.append(unique[:, :3] @ root.T)
    if not tris:
        sys.exit(f"{dae_path}: no triangles")
    return np.concatenate(tris), np.concatenate(kept)


def write_obj(path, tris):
    # Shared vertices, so the mesh checker sees the mesh's real topology.
    verts, index = {}, []
    for t in tris:
        for v in t:
            key = tuple(v)
            index.append(verts.setdefault(key, len(verts)))
    with open(path, "w") as f:
        f.write(f"# converted by benches/cad/convert.py from OMPL.app; {len(tris)} triangles\n")
        for v in verts:
            f.write(f"v {v[0]:.9g} {v[1]:.9g} {v[2]:.9g}\n")
        for i in range(0, len(index), 3):
            f.write(f"f {index[i] + 1} {index[i + 1] + 1} {index[i + 2] + 1}\n")


def axis_angle(theta, axis):
    axis = np.asarray(axis, dtype=float)
    n = np.linalg.norm(axis)
    if n == 0.0 or theta == 0.0:
        return np.eye(3)
    x, y, z = axis / n
    c, s, C = math.cos(theta), math.sin(theta), 1 - math.cos(theta)
    return np.array([
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ])


def rpy(r):
    """Roll, pitch, yaw of r = Rz(yaw)·Ry(pitch)·Rx(roll) (our scenes' convention)."""
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    return [math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])]


def quat_rotation(qx, qy, qz, qw):
    return np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])


def pose(cfg, which):
    p = [float(cfg[f"{which}.{k}"]) for k in "xyz"]
    axis = [float(cfg[f"{which}.axis.{k}"]) for k in "xyz"]
    return np.array(p), axis_angle(float(cfg[f"{which}.theta"]), axis)


def coal_check(robot, env, poses):
    """Indices of the poses (position in file units, rotation) at which coal finds a
    collision between the two meshes."""
    import coal

    def model(tris):
        m = coal.BVHModelOBBRSS()
        m.beginModel(len(tris), 3 * len(tris))
        m.addVertices(tris.reshape(-1, 3).astype(np.float64))
        m.addTriangles(np.arange(3 * len(tris), dtype=np.int64).reshape(-1, 3))
        m.endModel()
        return m

    r, e = model(robot), model(env)
    req, res = coal.CollisionRequest(), coal.CollisionResult()
    bad = []
    for i, (p, rot) in enumerate(poses):
        res.clear()
        coal.collide(r, coal.Transform3s(rot, p), e, coal.Transform3s(), req, res)
        if res.isCollision():
            bad.append(i)
    return bad


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("resources", help="OMPL.app's resources/3D")
    ap.add_argument("out")
    ap.add_argument("--puzzles", default=",".join(PUZZLES))
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "meshes"), exist_ok=True)
    failed = False
    for name in a.puzzles.split(","):
        if name not in PUZZLES:
            sys.exit(f"unknown puzzle `{name}`; known: {', '.join(PUZZLES)}")
        cfg_file, scale = PUZZLES[name]
        cfg = read_cfg(os.path.join(a.resources, cfg_file))
        robot, robot_kept = triangles(os.path.join(a.resources, cfg["robot"]))
        env, _ = triangles(os.path.join(a.resources, cfg["world"]))
        centre = robot_kept.mean(axis=0)
        robot = robot - centre
        write_obj(os.path.join(a.out, "meshes", f"{name}-object.obj"), robot)
        write_obj(os.path.join(a.out, "meshes", f"{name}-env.obj"), env)
        lo = [float(cfg[f"volume.min.{k}"]) * scale for k in "xyz"]
        hi = [float(cfg[f"volume.max.{k}"]) * scale for k in "xyz"]
        start, goal = pose(cfg, "start"), pose(cfg, "goal")

        def vec(v):
            return "[" + ", ".join(f"{x:.9g}" for x in v) + "]"

        with open(os.path.join(a.out, f"{name}.toml"), "w") as f:
            f.write(f"# OMPL.app's {cfg_file} converted by benches/cad/convert.py "
                    f"({scale} m per file unit).\n")
            f.write(f'name = "{name}"\n\n[bounds]\nmin_m = {vec(lo)}\nmax_m = {vec(hi)}\n')
            for which, (p, rot) in (("start", start), ("goal", goal)):
                f.write(f"\n[{which}]\nposition_m = {vec(p * scale)}\nrpy_rad = {vec(rpy(rot))}\n")
            f.write(f'\n[[obstacles]]\nshape = "mesh"\nfile = "meshes/{name}-env.obj"\n'
                    f"scale = {scale}\n")
            f.write(f'\n[[moving_object]]\nshape = "mesh"\nfile = "meshes/{name}-object.obj"\n'
                    f"scale = {scale}\n")
        poses = [start, goal]
        path_file = os.path.join(a.resources, cfg_file.replace(".cfg", ".path"))
        if os.path.exists(path_file):
            with open(path_file) as f:
                for line in f:
                    v = [float(x) for x in line.split()]
                    if len(v) == 7:
                        poses.append((np.array(v[:3]), quat_rotation(*v[3:])))
        bad = coal_check(robot, env, poses)
        print(f"{name}: object {len(robot)} triangles, environment {len(env)}; "
              f"centre {np.round(centre, 3).tolist()}; coal: {len(poses) - len(bad)} of "
              f"{len(poses)} poses free (start, goal, {len(poses) - 2} stored path waypoints)"
              + (f"; colliding: {bad[:10]}" if bad else ""))
        failed |= bool(bad)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
