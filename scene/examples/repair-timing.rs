//! Times [`scene::repair::repair`] on a big double-sided, partly flipped bumpy sphere (the
//! shape of a CAD export of a dense part), beside [`scene::topology::Topology::of`], which
//! every scene load and check also runs. Prints the median and the fastest of the repeats
//! and the process's peak memory.
//!
//! `cargo run --release -p scene --example repair-timing -- [TRIANGLES] [REPEATS]`
//! (defaults: 1 310 720 triangles before the twins are added, 5 repeats).

use scene::MeshData;
use scene::repair::repair;
use scene::topology::Topology;
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let mut number = |default: usize| {
        args.next()
            .map_or(Some(default), |a| a.replace('_', "").parse().ok())
    };
    let (Some(triangles), Some(repeats)) = (number(1_310_720), number(5)) else {
        eprintln!("usage: repair-timing [TRIANGLES] [REPEATS]");
        std::process::exit(2);
    };
    let repeats = repeats.max(1);
    // 2·segments·(rings − 1) triangles, segments = 1.6·(rings − 1): the 1 310 720 of
    // issue 36 are 1024 segments of 641 rings.
    let bands = ((triangles as f64 / 3.2).sqrt().round() as u32).max(1);
    let segments = ((triangles as f64 / f64::from(2 * bands)).round() as u32).max(3);
    let sphere = MeshData::bumpy_sphere("bumpy sphere", 0.25, bands + 1, segments);
    // Every triangle twice, the first of each pair flipped for one in seven.
    let mut t: Vec<[u32; 3]> = sphere
        .triangles
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| if i % 7 == 0 { [a, c, b] } else { [a, b, c] })
        .collect();
    let twins: Vec<[u32; 3]> = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
    t.extend(twins);
    let mesh = match MeshData::new("double-sided bumpy sphere", sphere.vertices_m.clone(), t) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let time = |f: &dyn Fn()| {
        let mut s: Vec<f64> = (0..repeats)
            .map(|_| {
                let started = Instant::now();
                f();
                started.elapsed().as_secs_f64()
            })
            .collect();
        s.sort_by(f64::total_cmp);
        (s[s.len() / 2], s[0])
    };
    let r = repair(&mesh);
    println!("{}", r.report);
    let ok = r.mesh.triangles == sphere.triangles;
    println!(
        "{} vertices, {} triangles in, {} out; repaired triangles equal the sphere's: {ok}",
        mesh.vertices_m.len(),
        mesh.triangles.len(),
        r.mesh.triangles.len()
    );
    drop(r);
    let (repair_med, repair_min) = time(&|| {
        std::hint::black_box(repair(std::hint::black_box(&mesh)));
    });
    let (topo_med, topo_min) = time(&|| {
        std::hint::black_box(Topology::of(std::hint::black_box(&mesh)));
    });
    println!("| step | median s | fastest s |");
    println!("|---|---|---|");
    println!("| repair | {repair_med:.3} | {repair_min:.3} |");
    println!("| Topology::of (for comparison) | {topo_med:.3} | {topo_min:.3} |");
    if let Ok(status) = std::fs::read_to_string("/proc/self/status")
        && let Some(line) = status.lines().find(|l| l.starts_with("VmHWM"))
    {
        println!(
            "peak memory (VmHWM): {}",
            line.trim_start_matches("VmHWM:").trim()
        );
    }
}
