//! Writes each fuzz target's seeds (`fuzz_checks::seeds`) into its corpus folder,
//! `tests/fuzz/corpus/<target>/seed-*` (or under the folder given as the one argument).
//! Seeds longer than libFuzzer's default input limit are left out.
//!
//! `cargo run -p fuzz-checks --example write_seeds [corpus-dir]`

use fuzz_checks::seeds::{self, MAX_SEED_LEN};
use std::path::PathBuf;

fn main() -> std::io::Result<()> {
    let root = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus"));
    for (target, _) in fuzz_checks::TARGETS {
        let dir = root.join(target);
        std::fs::create_dir_all(&dir)?;
        let mut written = 0;
        for s in seeds::of(target) {
            if s.bytes.len() <= MAX_SEED_LEN {
                std::fs::write(dir.join(&s.name), &s.bytes)?;
                written += 1;
            }
        }
        println!("{}: {written} seeds", dir.display());
    }
    Ok(())
}
