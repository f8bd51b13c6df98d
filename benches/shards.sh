#!/usr/bin/env bash
# Sharded-bake timings: for each N, runs shards 0..N-1 one after another as separate
# processes (as N machines would run them at once), then the merge. Prints a Markdown
# table: the slowest shard is the wall time on N machines, plus the merge.
#   cargo build --release && bash benches/shards.sh SCENE_DIR [relight-binary] ["1 2 4"]
set -euo pipefail
SCENE=${1:?scene folder}
BIN=${2:-target/release/relight}
COUNTS=${3:-"1 2 4"}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
peak() { grep "Maximum resident" "$1" | awk '{printf "%.0f", $6/1024}'; }
secs() { grep "Elapsed (wall" "$1" | awk '{print $NF}' | awk -F: '{ if (NF == 3) print $1*3600+$2*60+$3; else print $1*60+$2 }'; }
echo "| N | shards (s, each) | slowest shard (s) | shard peak (MB) | merge (s) | merge peak (MB) |"
echo "|---|---|---|---|---|---|"
for n in $COUNTS; do
  cache="$WORK/cache-$n"
  each=""; slowest=0; speak=0
  for ((k = 0; k < n; k++)); do
    /usr/bin/time -v "$BIN" bake "$SCENE" --transfer hierarchical --shard "$k/$n" --cache "$cache" \
      >/dev/null 2>"$WORK/shard.time"
    t=$(secs "$WORK/shard.time"); p=$(peak "$WORK/shard.time")
    each="$each ${t}"
    slowest=$(echo "if ($t > $slowest) $t else $slowest" | bc)
    speak=$(( p > speak ? p : speak ))
  done
  /usr/bin/time -v "$BIN" bake "$SCENE" --transfer hierarchical --merge --cache "$cache" \
    >/dev/null 2>"$WORK/merge.time"
  printf "| %s |%s | %s | %s | %s | %s |\n" "$n" "$each" "$slowest" "$speak" \
    "$(secs "$WORK/merge.time")" "$(peak "$WORK/merge.time")"
done
