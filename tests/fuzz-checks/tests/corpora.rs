//! Every corpus file kept from fuzzing (`tests/fuzz/corpus/<target>/`), and every seed,
//! through its target's check: the fuzzers' findings as ordinary regression tests. A corpus
//! must hold more than [`MIN_FILES`] inputs, so that a missing or emptied one fails here
//! instead of passing silently.

use std::path::PathBuf;

/// Fewest corpus files a target may have.
const MIN_FILES: usize = 20;

fn corpus(target: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/corpus")
        .join(target)
}

#[test]
fn every_corpus_file_passes_its_targets_check() {
    for (target, check) in fuzz_checks::TARGETS {
        let dir = corpus(target);
        let entries = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e} (run tests/fuzz/run.sh)", dir.display()));
        let mut files: Vec<PathBuf> = entries
            .map(|e| e.expect("a corpus entry").path())
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        assert!(
            files.len() > MIN_FILES,
            "{}: {} inputs, expected more than {MIN_FILES}",
            dir.display(),
            files.len()
        );
        for file in &files {
            let bytes = std::fs::read(file).expect("a readable corpus file");
            // Name the input a failing check was given (a panic in `check` fails the test).
            let result = std::panic::catch_unwind(|| check(&bytes));
            assert!(result.is_ok(), "{target}: {} fails", file.display());
        }
    }
}

#[test]
fn every_seed_passes_its_targets_check() {
    for (target, check) in fuzz_checks::TARGETS {
        let seeds = fuzz_checks::seeds::of(target);
        assert!(!seeds.is_empty(), "{target}");
        for s in seeds {
            let result = std::panic::catch_unwind(|| check(&s.bytes));
            assert!(result.is_ok(), "{target}: seed {} fails", s.name);
        }
    }
}
