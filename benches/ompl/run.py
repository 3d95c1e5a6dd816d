#!/usr/bin/env python3
"""Our automatic RRT-Connect (`planner solve`) vs OMPL RRTConnect + FCL (ompl_solve).

Usage: benches/ompl/run.py --planner target/release/planner --seeds 20 --time-limit 10 \
           --out out/ompl [--scenes wall-hole,tunnels-1axis,silencer] \
           [--ours-args '--extend step'] [--ompl-args '--metric sum --segments per-component']
Writes OUT/runs.csv and OUT/summary.md; see docs/ompl-comparison.md.
"""
import argparse, csv, json, os, statistics, subprocess, tomllib

HERE = os.path.dirname(os.path.abspath(__file__))


def flatten(toml_path, out_path):
    """Scene TOML -> the line format ompl_solve reads (parts: shape, position, rpy)."""
    with open(toml_path, "rb") as f:
        s = tomllib.load(f)
    base = os.path.dirname(os.path.abspath(toml_path))
    lines = [f"space {s.get('space', 'se3')}",
             "bounds " + " ".join(map(str, s["bounds"]["min_m"] + s["bounds"]["max_m"])),
             "start " + " ".join(map(str, s["start"]["position_m"] + s["start"].get("rpy_rad", [0, 0, 0]))),
             "goal " + " ".join(map(str, s["goal"]["position_m"] + s["goal"].get("rpy_rad", [0, 0, 0])))]
    for key in ("start", "goal"):
        extra = set(s[key]) - {"position_m", "rpy_rad"}
        if extra:
            raise SystemExit(f"{toml_path}: [{key}] {sorted(extra)} not supported by ompl_solve")
    for key, tag in (("obstacles", "obs"), ("moving_object", "mov")):
        for p in s.get(key, []):
            extra = set(p) - {"shape", "half_extents_m", "radius_m", "file", "scale", "position_m", "rpy_rad"}
            if extra:
                raise SystemExit(f"{toml_path}: {key} field(s) {sorted(extra)} not supported")
            pos = " ".join(map(str, p.get("position_m", [0, 0, 0])))
            if p["shape"] == "box":
                geom = "box " + " ".join(map(str, p["half_extents_m"]))
            elif p["shape"] == "sphere":
                geom = f"sphere {p['radius_m']}"
            elif p["shape"] == "mesh":
                geom = f"mesh {os.path.join(base, p['file'])} {p.get('scale', 1.0)}"
            else:
                raise SystemExit(f"{toml_path}: shape {p['shape']} not supported")
            rpy = " ".join(map(str, p.get("rpy_rad", [0, 0, 0])))
            lines.append(f"{tag} {geom} {pos} {rpy}")
    with open(out_path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--planner", default="target/release/planner")
    ap.add_argument("--ompl", default=os.path.join(HERE, "ompl_solve"))
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--time-limit", type=float, default=10)
    ap.add_argument("--step", type=float, default=0.05)
    ap.add_argument("--edge-resolution", type=float, default=0.005)
    ap.add_argument("--scenes", default="wall-hole,tunnels-1axis,silencer,crossing-planes,maze")
    ap.add_argument("--out", default="out/ompl")
    ap.add_argument("--ours-args", default="",
                    help="extra arguments for planner solve, e.g. '--extend step'")
    ap.add_argument("--ompl-args", default="",
                    help="extra arguments for ompl_solve, e.g. '--metric sum --segments per-component'")
    ap.add_argument("--summary-only", action="store_true",
                    help="rewrite OUT/summary.md from OUT/runs.csv (same options as the run)")
    a = ap.parse_args()
    if a.summary_only:
        with open(os.path.join(a.out, "runs.csv")) as f:
            rows = [dict(r, seed=int(r["seed"]), solved=r["solved"] == "True",
                         time_s=float(r["time_s"]), checks=int(r["checks"]),
                         nodes=int(r["nodes"])) for r in csv.DictReader(f)]
        summarize(a, rows, list(dict.fromkeys(r["scene"] for r in rows)))
        return
    os.makedirs(a.out, exist_ok=True)
    sdir = os.path.join(a.out, "scenes")
    subprocess.run([a.planner, "scenes", "--write", sdir], check=True, stdout=subprocess.DEVNULL)
    rows = []
    scenes = []
    for scene in a.scenes.split(","):
        flat = os.path.join(sdir, scene + ".txt")
        try:
            flatten(os.path.join(sdir, scene + ".toml"), flat)
        except SystemExit as e:
            print(f"skipping {scene}: {e}", flush=True)
            continue
        scenes.append(scene)
        for seed in range(1, a.seeds + 1):
            js = os.path.join(a.out, f"ours-{scene}-{seed}.json")
            subprocess.run([a.planner, "solve", "--scene", os.path.join(sdir, scene + ".toml"),
                            "--seed", str(seed), "--time-limit", str(a.time_limit),
                            "--step", str(a.step), "--edge-resolution", str(a.edge_resolution),
                            "--shortcut-attempts", "0", "--json", js] + a.ours_args.split(),
                           check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            r = json.load(open(js))
            rows.append(dict(scene=scene, impl="ours", seed=seed, solved=r["solved"],
                             time_s=r["time_s"], checks=r["collision_checks"], nodes=r["nodes"]))
            out = subprocess.run([a.ompl, flat, "--seed", str(seed), "--time-limit",
                                  str(a.time_limit), "--step", str(a.step),
                                  "--edge-resolution", str(a.edge_resolution)] + a.ompl_args.split(),
                                 check=True, capture_output=True, text=True).stdout
            r = json.loads(out)
            rows.append(dict(scene=scene, impl="ompl+fcl", seed=seed, solved=r["solved"],
                             time_s=r["time_s"], checks=r["collision_checks"], nodes=r["nodes"]))
            print(scene, seed, rows[-2]["solved"], round(rows[-2]["time_s"], 4),
                  rows[-1]["solved"], round(rows[-1]["time_s"], 4), flush=True)
    with open(os.path.join(a.out, "runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summarize(a, rows, scenes)


def summarize(a, rows, scenes):
    """OUT/summary.md from the rows (also run alone by --summary-only on OUT/runs.csv)."""
    md = ["| scene | impl | solved | median time (s), solved runs | median / mean time (s), unsolved at limit | median checks, solved runs | median nodes, solved runs | checks/s | µs per check |",
          "|---|---|---|---|---|---|---|---|---|"]
    for scene in scenes:
        for impl in ("ours", "ompl+fcl"):
            rs = [r for r in rows if r["scene"] == scene and r["impl"] == impl]
            ok = [r for r in rs if r["solved"]]
            med = f"{statistics.median(r['time_s'] for r in ok):.3f}" if ok else "—"
            at_limit = [r["time_s"] if r["solved"] else a.time_limit for r in rs]
            med_checks = f"{statistics.median(r['checks'] for r in ok):,.0f}" if ok else "—"
            med_nodes = f"{statistics.median(r['nodes'] for r in ok):,.0f}" if ok else "—"
            t = sum(r["time_s"] for r in rs)
            n = sum(r["checks"] for r in rs)
            md.append(f"| {scene} | {impl} | {len(ok)}/{len(rs)} | {med} | "
                      f"{statistics.median(at_limit):.3f} / {statistics.mean(at_limit):.3f} | "
                      f"{med_checks} | {med_nodes} | {n / t:,.0f} | {t * 1e6 / n:.2f} |")
    md.append("")
    md.append(f"{a.seeds} seeds, time limit {a.time_limit} s, step {a.step}, edge resolution "
              f"{a.edge_resolution} (weighted m), ours: `{a.ours_args or '(defaults)'}`, "
              f"ompl_solve: `{a.ompl_args or '(defaults)'}`. checks/s and µs per check: all runs' time / "
              "all runs' collision checks (includes tree work, so an upper bound per check).")
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
