#!/usr/bin/env bash
# Runs every fuzz target for a bounded time (default 60 s each) and prints how many inputs
# ran clean. Needs cargo-fuzz (`cargo install cargo-fuzz`). The machine's only toolchain is
# stable: RUSTC_BOOTSTRAP=1 lets it accept libFuzzer's -Z flags, and no sanitizer is used
# (the targets are safe Rust; the fuzzer looks for panics and failed assertions).
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-60}"
mkdir -p corpus/scene_toml corpus/guidance_sample corpus/spacemouse_report
cp -n ../../scene/scenes/*.toml corpus/scene_toml/ 2>/dev/null || true
for target in $(cargo fuzz list --fuzz-dir .); do
    echo "== $target (${seconds} s)"
    RUSTC_BOOTSTRAP=1 cargo fuzz run -s none --fuzz-dir . "$target" -- \
        -max_total_time="$seconds" 2>&1 | grep -E "^Done|crash-|panicked" || true
done
