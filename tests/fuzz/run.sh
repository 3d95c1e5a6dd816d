#!/usr/bin/env bash
# Runs the fuzz targets (all, or those named after the seconds) for a bounded time each
# (default 60 s) and prints how many inputs ran clean:
#
#   tests/fuzz/run.sh [seconds-per-target] [target...]
#
# Needs cargo-fuzz (`cargo install cargo-fuzz --locked`). The machine's only toolchain is
# stable: RUSTC_BOOTSTRAP=1 lets it accept libFuzzer's -Z flags, and no sanitizer is used
# (the targets are safe Rust; the fuzzer looks for panics and failed assertions).
#
# The corpora of the network decoders' targets (bridge_frame, ros2_guidance, ros2_device) are
# kept in git and replayed by `cargo test -p fuzz-checks`; after each run they are minimised
# (`cargo fuzz cmin`) so they stay small. Their seeds come from the gateways' own encoders:
# `cargo run -p fuzz-checks --example write_seeds` (re)writes them.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-60}"
shift $(($# > 0 ? 1 : 0))
kept="bridge_frame ros2_guidance ros2_device"
mkdir -p corpus/scene_toml corpus/guidance_sample corpus/spacemouse_report
for target in $kept; do
    mkdir -p "corpus/$target"
done
cp -n ../../scene/scenes/*.toml corpus/scene_toml/ 2>/dev/null || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(cargo fuzz list --fuzz-dir .)
fi
for target in "${targets[@]}"; do
    echo "== $target (${seconds} s)"
    RUSTC_BOOTSTRAP=1 cargo fuzz run -s none --fuzz-dir . "$target" -- \
        -max_total_time="$seconds" 2>&1 | grep -E "^Done|DONE|crash-|panicked" || true
    if [[ " $kept " == *" $target "* ]]; then
        RUSTC_BOOTSTRAP=1 cargo fuzz cmin -s none --fuzz-dir . "$target" 2>&1 |
            grep -E "MERGE-OUTER: [0-9]+ new files" || true
        echo "   corpus: $(find "corpus/$target" -type f | wc -l) files, $(du -sh "corpus/$target" | cut -f1)"
    fi
done
