#!/usr/bin/env python3
"""Fetch the real CAD exports the tests load (tests/tests/it/cad_exports.rs): every mesh of the
PyPI wheel rtb-data 2.0.0 (robot link and body meshes as exported by SolidWorks, MeshLab and
others: STL, OBJ and COLLADA; MIT licence, see tests/cad/LICENSE-rtb-data), each verified by
its SHA-256 (tests/cad/rtb-data-2.0.0.sha256, from the wheel's RECORD), and each COLLADA file
converted to OBJ (the project reads STL and OBJ) with trimesh and pycollada, pinned in
tests/cad/requirements.txt.

Usage (from the repository's root, before `cargo test --workspace`):
    python3 tests/cad/fetch.py

Makes a virtual environment in target/cad-data/venv (PyPI only; nothing is installed outside the
checkout), downloads the wheel with pip into target/cad-data, and writes the meshes under
target/cad-data/rtb-data-2.0.0/ with, for each COLLADA file `X.dae`, `X.dae.obj` and a line in
converted.tsv (`X.dae<TAB>ok` or `X.dae<TAB>why not`). Run again, it checks what is there and
does only what is missing. Exits non-zero, naming the file, when a hash does not match.
"""
import hashlib
import os
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
WHEEL = "rtb_data-2.0.0-py3-none-any.whl"
WHEEL_SHA256 = "ecbcad669eb4d91ef971311640683eab19e2310f2a2be5c04fa5d32c6f0efce6"
DATA = ROOT / "target" / "cad-data"
OUT = DATA / "rtb-data-2.0.0"
VENV = DATA / "venv"


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def manifest():
    rows = []
    for line in (HERE / "rtb-data-2.0.0.sha256").read_text().splitlines():
        if line and not line.startswith("#"):
            digest, path = line.split("  ", 1)
            rows.append((digest, path))
    return rows


def venv_python():
    py = VENV / "bin" / "python"
    if not py.exists():
        print(f"cad data: making {VENV}", flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "-r",
                    str(HERE / "requirements.txt")], check=True)
    return py


def fetch_wheel(py):
    wheel = DATA / WHEEL
    if not wheel.exists() or sha256(wheel) != WHEEL_SHA256:
        print("cad data: downloading rtb-data 2.0.0 from PyPI", flush=True)
        DATA.mkdir(parents=True, exist_ok=True)
        subprocess.run([str(py), "-m", "pip", "download", "--quiet", "--no-deps",
                        "--only-binary=:all:", "rtb-data==2.0.0", "-d", str(DATA)], check=True)
    got = sha256(wheel)
    if got != WHEEL_SHA256:
        sys.exit(f"cad data: {wheel}: SHA-256 {got}, expected {WHEEL_SHA256}")
    return wheel


def extract(wheel, rows):
    with zipfile.ZipFile(wheel) as z:
        for digest, path in rows:
            dest = OUT / path
            if dest.exists() and sha256(dest) == digest:
                continue
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(z.read(path))
            got = sha256(dest)
            if got != digest:
                dest.unlink()
                sys.exit(f"cad data: {path}: SHA-256 {got}, expected {digest}")


def convert(rows):
    """COLLADA to OBJ, in the venv (trimesh, pycollada): every geometry of the file's scene
    in its place, as one mesh."""
    import trimesh

    lines = []
    for _, path in rows:
        if not path.lower().endswith(".dae"):
            continue
        src = OUT / path
        dst = OUT / (path + ".obj")
        try:
            mesh = trimesh.load(str(src), force="mesh", process=False)
            if len(mesh.faces) == 0:
                raise ValueError("no triangles")
            if not dst.exists():
                dst.write_text(trimesh.exchange.obj.export_obj(mesh, include_normals=False,
                                                               include_texture=False))
            lines.append(f"{path}\tok\n")
        except Exception as e:  # a malformed file is recorded, not fatal
            reason = " ".join(str(e).split())[:200]
            lines.append(f"{path}\t{type(e).__name__}: {reason}\n")
    (OUT / "converted.tsv").write_text("".join(lines))
    failed = sum(1 for l in lines if not l.rstrip().endswith("\tok"))
    print(f"cad data: {len(lines) - failed} of {len(lines)} COLLADA files converted to OBJ")


def main():
    rows = manifest()
    if len(sys.argv) > 1 and sys.argv[1] == "--convert":
        convert(rows)
        return
    py = venv_python()
    extract(fetch_wheel(py), rows)
    print(f"cad data: {len(rows)} mesh files in {OUT}, each matching its SHA-256", flush=True)
    subprocess.run([str(py), __file__, "--convert"], check=True)


if __name__ == "__main__":
    main()
