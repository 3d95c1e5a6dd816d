//! Issue 36: long start-up work shows progress and stops on a signal with exit code 130,
//! leaving nothing behind: both programs, while they read a big scene and while the loop
//! builds its voxmap.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tests::{bin, unique_namespace, wait_for};

/// A scene whose one obstacle is a closed bumpy sphere (radius 0.25 m) of about
/// `triangles` triangles, written with its OBJ under a fresh folder.
fn big_scene(tag: &str, triangles: u32) -> (PathBuf, PathBuf) {
    sphere_scene(tag, triangles, 0.25)
}

/// [`big_scene`] with a sphere of `radius_m`.
fn sphere_scene(tag: &str, triangles: u32, radius_m: f64) -> (PathBuf, PathBuf) {
    use scene::{Bounds, MeshData, Part, Primitive, Scene, Se3, SpaceKind};
    let dir = std::env::temp_dir().join(format!("hrrtc-it-{tag}-{}", std::process::id()));
    let s = (f64::from(triangles).sqrt().round() as u32).max(8);
    let sphere = MeshData::bumpy_sphere("sphere.obj", radius_m, s / 2, s);
    let scene = Scene {
        name: format!("big-{tag}"),
        obstacles: vec![Part {
            primitive: Primitive::Mesh {
                mesh: Arc::new(sphere),
            },
            pose: Se3::identity(),
        }],
        moving_object: vec![Part::axis_box([0.02, 0.02, 0.02], [0.0, 0.0, 0.0])],
        bounds: Bounds {
            min_m: nalgebra::Vector3::repeat(-0.45),
            max_m: nalgebra::Vector3::repeat(0.45),
        },
        start: Se3::from_xyz(-0.4, 0.0, 0.0),
        goal: Se3::from_xyz(0.4, 0.0, 0.0),
        space: SpaceKind::Se3,
        route: Vec::new(),
    };
    let file = scene.write_to_dir(&dir).expect("scene written");
    (dir, file)
}

/// A child whose stderr is collected (and echoed on failure by the assertions).
struct Watched {
    child: Child,
    err: Arc<Mutex<String>>,
    reader: std::thread::JoinHandle<()>,
}

impl Watched {
    fn spawn(program: &Path, args: &[&str]) -> Watched {
        let mut child = Command::new(program)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        let err = Arc::new(Mutex::new(String::new()));
        let stderr = child.stderr.take().expect("piped stderr");
        let sink = err.clone();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let mut s = sink.lock().unwrap();
                s.push_str(&line);
                s.push('\n');
            }
        });
        Watched { child, err, reader }
    }

    fn stderr(&self) -> String {
        self.err.lock().unwrap().clone()
    }

    /// Waits until its stderr holds `text`.
    fn wait_for_text(&self, text: &str) {
        wait_for(
            &format!("'{text}' on stderr"),
            Duration::from_secs(120),
            || self.stderr().contains(text).then_some(()),
        );
    }

    /// Sends `signal`; the exit code and how long it took to exit.
    fn interrupt(&mut self, signal: i32) -> (Option<i32>, Duration) {
        let sent = Instant::now();
        // SAFETY: kill(2) on a child we spawned and have not reaped.
        unsafe { libc::kill(self.child.id() as libc::pid_t, signal) };
        let status = wait_for("exit", Duration::from_secs(30), || {
            self.child.try_wait().ok().flatten()
        });
        let took = sent.elapsed();
        // Its last lines may still be in the pipe when it has exited: read to the end (the
        // pipe closes with the process; nothing it started holds it at this stage).
        wait_for("the end of its stderr", Duration::from_secs(10), || {
            self.reader.is_finished().then_some(())
        });
        (status.code(), took)
    }
}

impl Drop for Watched {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Processes whose command line holds `needle` (from /proc).
fn processes_with(needle: &str) -> Vec<u32> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            std::fs::read(format!("/proc/{pid}/cmdline"))
                .is_ok_and(|c| String::from_utf8_lossy(&c).contains(needle))
        })
        .collect()
}

/// The loop's demo building the voxmap of a 20 k-triangle sphere at 1 mm shows its
/// progress (a log line: the output is a pipe), and Ctrl-C stops it promptly with exit code
/// 130, before any planner was started.
#[test]
fn the_loop_stops_on_ctrl_c_while_it_builds_its_voxmap() {
    // Big scenes: reading and voxmap builds keep both cores busy.
    let _cores = tests::one_loop_at_a_time();
    let (dir, file) = big_scene("vox", 20_000);
    let ns = unique_namespace("startup");
    let mut demo = Watched::spawn(
        &bin("haptic-loop"),
        &[
            "demo",
            "--namespace",
            &ns,
            "--scene",
            file.to_str().unwrap(),
            "--no-voxmap-cache",
            "--priority",
            "0",
            "--no-mlock",
        ],
    );
    demo.wait_for_text("voxmap: [");
    let (code, took) = demo.interrupt(libc::SIGINT);
    let err = demo.stderr();
    assert_eq!(code, Some(130), "{err}");
    eprintln!("stopped {} ms after SIGINT", took.as_millis());
    assert!(err.contains("stopped during start-up"), "{err}");
    assert!(processes_with(&ns).is_empty(), "a planner of {ns} runs on");
    let _ = std::fs::remove_dir_all(dir);
}

/// Both programs, while they read a 1.3 M-triangle scene file: SIGTERM ends them at once
/// with exit code 130 (nothing is held yet to stop in order).
#[test]
fn both_programs_stop_on_sigterm_while_they_read_a_big_scene() {
    // Big scenes: reading and voxmap builds keep both cores busy.
    let _cores = tests::one_loop_at_a_time();
    let (dir, file) = big_scene("read", 1_310_720);
    let scene_arg = file.to_str().unwrap().to_owned();
    let ns = unique_namespace("startread");
    for (program, args) in [
        (
            "haptic-loop",
            vec![
                "run",
                "--namespace",
                &ns,
                "--scene",
                &scene_arg,
                "--no-voxmap-cache",
            ],
        ),
        ("planner", vec!["solve", "--scene", &scene_arg]),
    ] {
        let mut p = Watched::spawn(&bin(program), &args);
        // Reading the scene's 40 MB OBJ takes seconds: signal it once it says so.
        p.wait_for_text("reading scene");
        let (code, took) = p.interrupt(libc::SIGTERM);
        assert_eq!(code, Some(130), "{program}: {}", p.stderr());
        assert!(
            p.stderr().contains("stopped during start-up"),
            "{}",
            p.stderr()
        );
        eprintln!("{program} stopped {} ms after SIGTERM", took.as_millis());
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The voxmap built at the first start is read at the second; a damaged file is reported
/// and built again, never read.
#[test]
fn the_second_start_reads_the_voxmap_from_the_cache_and_a_damaged_one_is_rebuilt() {
    // Big scenes: reading and voxmap builds keep both cores busy.
    let _cores = tests::one_loop_at_a_time();
    let (dir, file) = sphere_scene("cache", 5_000, 0.05);
    let cache = dir.join("cache");
    let start = || {
        let ns = unique_namespace("cache");
        let out = Command::new(bin("haptic-loop"))
            .args([
                "run",
                "--namespace",
                &ns,
                "--scene",
                file.to_str().unwrap(),
                "--voxmap-cache-dir",
                cache.to_str().unwrap(),
                "--duration-s",
                "0.3",
                "--priority",
                "0",
                "--no-mlock",
            ])
            .output()
            .expect("haptic-loop runs");
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        err
    };
    let first = start();
    assert!(first.contains("voxmap written to"), "{first}");
    let second = start();
    assert!(second.contains("voxmap read from"), "{second}");
    assert!(second.contains("loaded from the cache"), "{second}");
    let files: Vec<PathBuf> = std::fs::read_dir(&cache)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let mut bytes = std::fs::read(&files[0]).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&files[0], &bytes).unwrap();
    let third = start();
    assert!(
        third.contains("checksum mismatch") && third.contains("voxmap written to"),
        "{third}"
    );
    let _ = std::fs::remove_dir_all(dir);
}
