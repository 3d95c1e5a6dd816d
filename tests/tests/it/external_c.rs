//! Issue 19: a C client. The generated wire header (with its static asserts of every size
//! and offset) and the client API compile under a strict C11 compiler, and the example
//! program reads a live loop's state through `libhrrtc_c` and guides the arm.

use std::path::{Path, PathBuf};
use std::process::Command;
use tests::{bin_dir, one_loop_at_a_time, unique_namespace};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The example compiled against the library of this build's profile.
fn print_state() -> PathBuf {
    let lib_dir = bin_dir();
    assert!(
        lib_dir.join("libhrrtc_c.so").exists(),
        "libhrrtc_c.so was not built"
    );
    let out = std::env::temp_dir().join(format!("print_state_{}", std::process::id()));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic"])
        .arg("-I")
        .arg(repo().join("ipc-types/include"))
        .arg(repo().join("ipc-types/c/examples/print_state.c"))
        .arg("-L")
        .arg(lib_dir)
        .args(["-lhrrtc_c", "-lm"])
        .arg(format!("-Wl,-rpath,{}", lib_dir.display()))
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap_or_else(|e| panic!("cannot run the C compiler `{cc}`: {e}"));
    assert!(status.success(), "the C example did not compile");
    out
}

/// `(sequence, guidance force x N, freshness)` of each line the example printed.
fn lines(stdout: &str) -> Vec<(u64, f64, u32)> {
    stdout
        .lines()
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            let at = |key: &str| w[w.iter().position(|x| *x == key).expect(key) + 1];
            (
                at("seq").parse().expect("seq"),
                at("guidance_n").parse().expect("guidance"),
                at("freshness").parse().expect("freshness"),
            )
        })
        .collect()
}

#[test]
fn issue_19_a_c_program_reads_the_state_and_guides_the_arm() {
    let exe = print_state();
    let _serial = one_loop_at_a_time();
    let ns = unique_namespace("c");
    let mut lp = tests::start_loop(
        &ns,
        &["--priority", "0", "--no-contact", "--duration-s", "60"],
    );
    // Reading only: 5 lines at least 0.1 s apart (the example sleeps that long between
    // them); the loop ticks meanwhile, so each line shows a later tick.
    let out = Command::new(&exe)
        .args([&ns, "5"])
        .output()
        .expect("run the example");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = lines(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(read.len(), 5);
    for pair in read.windows(2) {
        assert!(pair[1].0 >= pair[0].0 + 20, "ticks between lines: {read:?}");
    }
    // Guiding: F_s = 0.3 N along scene x is rendered, fresh.
    let out = Command::new(&exe)
        .args([&ns, "8", "0.3"])
        .output()
        .expect("run the example");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let guided = lines(&String::from_utf8_lossy(&out.stdout));
    let (_, force, freshness) = *guided.last().expect("lines");
    assert!((force - 0.3).abs() < 1e-3, "rendered {force} N: {guided:?}");
    assert_eq!(freshness, 1, "fresh");
    assert!(lp.is_running());
    lp.signal(libc::SIGTERM);
    let st = lp
        .wait_timeout(std::time::Duration::from_secs(10))
        .expect("loop stops");
    assert!(st.success());
}
