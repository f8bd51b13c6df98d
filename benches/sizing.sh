#!/usr/bin/env bash
# Sizing sweep: bake time and peak memory, and a replica's memory after a cached load,
# against patch count, for every transfer mode. Prints a Markdown table.
#   cargo build --release && bash benches/sizing.sh [relight-binary]
# SPECS="mode:target ..." picks other rows (e.g. SPECS="hierarchical:20000").
set -euo pipefail
BIN=${1:-target/release/relight}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
peak() { grep "Maximum resident" "$1" | awk '{printf "%.0f", $6/1024}'; }
echo "| mode | target | patches | cold bake (s) | bake peak (MB) | cached load peak (MB) | cache file (MB) |"
echo "|---|---|---|---|---|---|---|"
SPECS=${SPECS:-"factored:2000 factored:4000 factored:8000 columns:2500 columns:5000 columns:10000 columns:20000 hierarchical:5000 hierarchical:10000 hierarchical:20000 hierarchical:100000"}
for spec in $SPECS; do
  mode=${spec%%:*}; target=${spec##*:}
  dir="$WORK/room-$mode-$target"
  "$BIN" bench --make-scene "$dir" >/dev/null
  sed -i "s/^transfer = .*/transfer = \"$mode\"/; s/^target_patches = .*/target_patches = $target/" "$dir/scene.toml"
  cache="$WORK/cache-$mode-$target"
  start=$(date +%s.%N)
  /usr/bin/time -v "$BIN" bake "$dir" --cache "$cache" >"$WORK/bake.out" 2>"$WORK/bake.time"
  end=$(date +%s.%N)
  patches=$(awk '/^patches/ {print $2}' "$WORK/bake.out")
  /usr/bin/time -v "$BIN" radiosity "$dir" --cache "$cache" --json >/dev/null 2>"$WORK/load.time"
  size=$(du -m "$cache" | tail -1 | cut -f1)
  printf "| %s | %s | %s | %.1f | %s | %s | %s |\n" "$mode" "$target" "$patches" \
    "$(echo "$end - $start" | bc)" "$(peak "$WORK/bake.time")" "$(peak "$WORK/load.time")" "$size"
done
