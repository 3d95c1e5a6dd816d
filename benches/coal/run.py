#!/usr/bin/env python3
"""coal (the former hpp-fcl) on the cases `mesh-checks --export DIR` wrote: the same meshes
(BVHModelOBBRSS, coal's default for meshes) and the same poses; checks coal's verdicts
against ours and prints the time per check beside ours, from one run.

Setup (not a project dependency): python3 -m venv target/coal-venv &&
    target/coal-venv/bin/pip install coal==3.0.3
Usage: target/release/mesh-checks --poses 300 --repeats 3 --export target/mesh-cases &&
    target/coal-venv/bin/python benches/coal/run.py target/mesh-cases [--repeats 3]
(or `mesh-checks --scene FILE,... --export DIR` for the meshes of scene files, each case with
its own poses).

Each coal call goes through Python; the time of a call that returns at once (two models
far apart, rejected at their root bounding volumes) is printed as the per-call floor, so
coal's own cost is about its time minus that floor.
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--contact", action="store_true",
                    help="ask coal for the contact too (its default request), not only yes/no")
    a = ap.parse_args()
    with open(os.path.join(a.dir, "cases.json")) as f:
        cases = json.load(f)
    def transforms(rows):
        return [coal.Transform3s(rotation(*p[3:]), np.array(p[:3])) for p in rows]

    shared = transforms(cases["poses"])
    identity = coal.Transform3s()
    far = coal.Transform3s(np.eye(3), np.array([10.0, 0.0, 0.0]))
    # A yes/no answer, as `is_free` gives: no contact points or penetration depth (coal's
    # default request computes one contact with EPA).
    req = coal.CollisionRequest()
    req.enable_contact = a.contact
    req.num_max_contacts = 1
    res = coal.CollisionResult()
    print("| case (triangles per mesh) | coal µs | coal floor µs (call overhead) | ours µs | parry's mesh test µs | ours / coal | disagreements |")
    print("|---|---|---|---|---|---|---|")
    bad = 0
    for case in cases["sizes"]:
        poses = transforms(case["poses"]) if "poses" in case else shared
        obstacle = model(os.path.join(a.dir, case["obstacle_obj"]))
        obj = model(os.path.join(a.dir, case["object_obj"]))

        def collide(t):
            res.clear()
            coal.collide(obj, t, obstacle, identity, req, res)
            return res.isCollision()

        verdicts = [collide(t) for t in poses]
        disagree = sum(v != ours for v, ours in zip(verdicts, case["colliding"]))
        bad += disagree
        t0 = time.perf_counter()
        for _ in range(a.repeats):
            for t in poses:
                collide(t)
        coal_us = (time.perf_counter() - t0) * 1e6 / (a.repeats * len(poses))
        t0 = time.perf_counter()
        for _ in range(a.repeats * len(poses)):
            collide(far)
        floor_us = (time.perf_counter() - t0) * 1e6 / (a.repeats * len(poses))
        print(f"| {case.get('label', case['triangles'])} | {coal_us:.2f} | {floor_us:.2f} | {case['is_free_us']:.2f} | "
              f"{case['parry_us']:.2f} | {case['is_free_us'] / coal_us:.2f} | {disagree} |")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
