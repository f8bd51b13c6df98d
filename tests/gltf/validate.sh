#!/usr/bin/env bash
# Exports bundled scenes as glTF binary with `relight export` and checks every file, and the
# bundled glTF scene, with the Khronos glTF validator (npm package gltf-validator): any
# error fails.
#
#   tests/gltf/validate.sh                                  # uses target/release/relight
#   RELIGHT_BIN=target/debug/relight tests/gltf/validate.sh # any built binary (.ci/run uses
#                                                           # the one `cargo test` built)
#
# RELIGHT_CACHE names the bake cache folder (CI passes the one the test suite filled).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=${RELIGHT_BIN:-target/release/relight}
version=2.0.0-dev.3.10
tool=target/gltf-validator
out=target/gltf-exports
cache=${RELIGHT_CACHE:-$out/cache}

if ! command -v npm >/dev/null; then
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq nodejs npm >/dev/null
fi
if [ ! -f "$tool/node_modules/gltf-validator/package.json" ] ||
   ! grep -q "\"version\": \"$version\"" "$tool/node_modules/gltf-validator/package.json"; then
  mkdir -p "$tool"
  npm install --silent --no-audit --no-fund --prefix "$tool" "gltf-validator@$version" >/dev/null
fi
cp tests/gltf/validate.mjs "$tool/validate.mjs"

mkdir -p "$out"
# Relightable exports of the small bundled scenes (the office-floor takes minutes to bake),
# with both tone maps, and one without the per-group attributes.
"$bin" export scenes/cornell-box -o "$out/cornell-box.glb" --cache "$cache" --tonemap clamp
"$bin" export scenes/desk-room -o "$out/desk-room.glb" --cache "$cache" --light lamp=0.4 --light ceiling=1,0.8,0.6
"$bin" export scenes/office -o "$out/office.glb" --cache "$cache"
"$bin" export scenes/office -o "$out/office-lean.glb" --cache "$cache" --no-groups --exposure -3
"$bin" export scenes/gallery -o "$out/gallery.glb" --cache "$cache" --light spots=0.5
# The exports, and the bundled glTF scene itself.
node "$tool/validate.mjs" "$out"/*.glb scenes/gallery/gallery.gltf
