#!/usr/bin/env python3
"""coal (the former hpp-fcl) on the cases `mesh-checks --export DIR` wrote: the same parts
(meshes as BVHModelOBBRSS, coal's default for meshes; boxes and spheres as coal's Box and
Sphere) and the same poses; checks coal's verdicts against ours and prints the time per
check beside ours, from one run.

Setup (not a project dependency): python3 -m venv target/coal-venv &&
    target/coal-venv/bin/pip install coal==3.0.3
Usage: target/release/mesh-checks --poses 300 --repeats 3 --export target/mesh-cases &&
    target/coal-venv/bin/python benches/coal/run.py target/mesh-cases [--repeats 3]
(or `mesh-checks --scene FILE,... --export DIR` for the parts of scene files).

A check tests every object part against every obstacle part, as ours does, and stops at
the first pair in collision. Each coal call goes through Python; the time of a call that
returns at once (two parts far apart, rejected at their root bounding volumes) is the
per-call floor, and the floor of a check is that times the calls the check made. coal's own
cost is its time minus that floor, the column ours is compared with.
"""
import argparse, json, os, sys, time

import coal
import numpy as np


def read_obj(path):
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                verts.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                tris.append([int(x.split("/")[0]) - 1 for x in p[1:4]])
    return np.array(verts, dtype=np.float64), np.array(tris, dtype=np.int64)


def model(path):
    verts, tris = read_obj(path)
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(tris), len(verts))
    m.addVertices(verts)
    m.addTriangles(tris)
    m.endModel()
    return m


def rotation(qw, qx, qy, qz):
    return np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])


def transform(p):
    return coal.Transform3s(rotation(*p[3:]), np.array(p[:3]))


def geometry(d, part):
    if part["kind"] == "mesh":
        return model(os.path.join(d, part["obj"]))
    if part["kind"] == "box":
        return coal.Box(*[2.0 * h for h in part["half_extents_m"]])
    if part["kind"] == "sphere":
        return coal.Sphere(part["radius_m"])
    raise ValueError(f"unknown part kind {part['kind']!r}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--contact", action="store_true",
                    help="ask coal for the contact too (its default request), not only yes/no")
    a = ap.parse_args()
    with open(os.path.join(a.dir, "cases.json")) as f:
        cases = json.load(f)
    far = coal.Transform3s(np.eye(3), np.array([10.0, 0.0, 0.0]))
    # A yes/no answer, as `is_free` gives: no contact points or penetration depth (coal's
    # default request computes one contact with EPA).
    req = coal.CollisionRequest()
    req.enable_contact = a.contact
    req.num_max_contacts = 1
    res = coal.CollisionResult()
    print("| case (triangles) | coal µs | coal floor µs (Python calls) | coal less its floor µs | ours µs | parry µs | ours / coal less floor | disagreements |")
    print("|---|---|---|---|---|---|---|---|")
    bad = 0
    for case in cases["sizes"]:
        obstacles = [(geometry(a.dir, p), transform(p["pose"])) for p in case["obstacle"]]
        objects = [(geometry(a.dir, p), transform(p["pose"])) for p in case["object"]]
        # Each pose's object parts in the scene frame, composed before timing.
        placed = [[(g, transform(q) * t) for g, t in objects] for q in case["poses"]]
        calls = [0]

        def collide(parts):
            for g1, t1 in parts:
                for g2, t2 in obstacles:
                    calls[0] += 1
                    res.clear()
                    coal.collide(g1, t1, g2, t2, req, res)
                    if res.isCollision():
                        return True
            return False

        verdicts = [collide(parts) for parts in placed]
        disagree = sum(v != ours for v, ours in zip(verdicts, case["colliding"]))
        bad += disagree
        calls[0] = 0
        t0 = time.perf_counter()
        for _ in range(a.repeats):
            for parts in placed:
                collide(parts)
        n = a.repeats * len(placed)
        coal_us = (time.perf_counter() - t0) * 1e6 / n
        calls_per_check = calls[0] / n
        g1, g2 = objects[0][0], obstacles[0][0]
        t0 = time.perf_counter()
        for _ in range(n):
            res.clear()
            coal.collide(g1, far, g2, obstacles[0][1], req, res)
        floor_us = (time.perf_counter() - t0) * 1e6 / n * calls_per_check
        own_us = max(coal_us - floor_us, 1e-3)
        print(f"| {case.get('label', case['triangles'])} | {coal_us:.2f} | {floor_us:.2f} ({calls_per_check:.1f}) | "
              f"{own_us:.2f} | {case['is_free_us']:.2f} | {case['parry_us']:.2f} | "
              f"{case['is_free_us'] / own_us:.2f} | {disagree} |")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
