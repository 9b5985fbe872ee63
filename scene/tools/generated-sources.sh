#!/usr/bin/env bash
# Writes the Rust the firmware's build script generates for every scene in scenes/
# (OUT_DIR/scene.rs, or the build script's refusal) into the directory $1, one file per
# scene, so that two runs (before and after a change of the code generation) can be
# compared with `diff -r`. Runs `cargo check` on the firmware for the QEMU board (the
# build script runs under check too) in the worktree's own firmware target directory.
set -u
out=${1:?usage: generated-sources.sh OUT_DIR}
root=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
cd "$root"
find scenes -name '*.toml' ! -name commissioning.toml | sort | while read -r scene; do
    name=$(echo "${scene#scenes/}" | tr / _)
    log=$(mktemp)
    SCENE="$root/$scene" nice -n 5 cargo check --release --quiet \
        --manifest-path firmware/Cargo.toml --features qemu \
        --target thumbv7em-none-eabihf --target-dir target/firmware/cargo \
        --message-format=json >"$log.json" 2>"$log"
    dir=$(grep '"reason":"build-script-executed"' "$log.json" | grep '"package_id":"[^"]*firmware#' \
        | sed 's/.*"out_dir":"\([^"]*\)".*/\1/' | tail -1)
    if [ -n "$dir" ] && [ -f "$dir/scene.rs" ]; then
        cp "$dir/scene.rs" "$out/$name.rs"
        echo "$scene: generated"
    else
        # The build script refused the scene: keep its message (the panic's text).
        grep -A3 "panicked at" "$log" | sed -e "/panicked at/d" -e "s#$root#ROOT#g" >"$out/$name.refused"
        echo "$scene: refused"
    fi
    rm -f "$log" "$log.json"
done
