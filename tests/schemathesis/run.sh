#!/usr/bin/env bash
# Fuzzes the HTTP API against its own OpenAPI document with schemathesis: a running
# `relight serve` must never answer 5xx, every status code, content type, header and body
# must be the documented one, requests the schemas call invalid must be refused, and valid
# ones must never be refused as malformed (400, 413, 415).
#
#   tests/schemathesis/run.sh                                  # builds target/release/relight
#   RELIGHT_BIN=target/debug/relight tests/schemathesis/run.sh # any built binary (.ci/run
#                                                              # uses the one `cargo test` built)
#
# ST_EXAMPLES (generated cases per operation in the fuzzing phase) and ST_SEED change the
# run; the defaults are what CI runs. RELIGHT_CACHE names a bake cache folder to use (CI
# passes the one the test suite filled, so the bundled scenes load instead of baking);
# by default a fresh one. Exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
here=$root/tests/schemathesis

st_version=4.32.5
examples=${ST_EXAMPLES:-120}
seed=${ST_SEED:-1729}
ready_wait=180

export PATH="$PATH:$HOME/.local/bin:$(python3 -c 'import sysconfig; print(sysconfig.get_path("scripts"))')"
if [ "$(schemathesis --version 2>/dev/null | awk '{print $NF}')" != "$st_version" ]; then
  python3 -m pip install -q "schemathesis==$st_version"
fi

if [ -n "${RELIGHT_BIN:-}" ]; then
  bin=$RELIGHT_BIN
else
  cargo build --release --quiet
  bin=target/release/relight
fi
[ -x "$bin" ] || { echo "schemathesis: no relight binary at $bin" >&2; exit 1; }

work=$(mktemp -d)
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
base=http://127.0.0.1:$port
# A 2 GB memory budget bounds the server's memory on a small CI machine: requests
# estimated beyond one request's share (the largest renders, batches) get a documented 422.
# The bundled scenes but the large office-floor (150,000 patches: `relight bench` measures
# it; baking it here would take most of the run).
mkdir -p "$work/scenes"
for d in scenes/*/; do
  name=$(basename "$d")
  [ "$name" = office-floor ] || ln -s "$PWD/$d" "$work/scenes/$name"
done
# Writes are on, with a token schemathesis sends (and leaves out to check the 401s).
token=$(python3 -c 'import secrets; print(secrets.token_hex(16))')
RELIGHT_ADMIN_TOKEN=$token RELIGHT_LOG=warn "$bin" serve --addr "127.0.0.1:$port" --scenes "$work/scenes" --static-dir static \
  --cache "${RELIGHT_CACHE:-$work/cache}" --memory-budget 2G >"$work/server.log" 2>&1 &
pid=$!
cleanup() {
  kill "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

t0=$SECONDS
# Ready means every scene baked: a failed scene would answer 503 to everything.
if ! python3 - "$base" "$pid" "$ready_wait" <<'EOF'; then
import json, os, sys, time, urllib.error, urllib.request
base, pid, wait = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
deadline = time.monotonic() + wait
while time.monotonic() < deadline:
    try:
        os.kill(pid, 0)
    except OSError:
        sys.exit("schemathesis: the server exited")
    try:
        with urllib.request.urlopen(base + "/readyz", timeout=5) as r:
            scenes = json.load(r)["scenes"]
        bad = [f"{s['id']}: {s.get('error')}" for s in scenes if s["status"] != "ready"]
        if bad:
            sys.exit("schemathesis: scenes failed to load: " + "; ".join(bad))
        sys.exit(0)
    except (urllib.error.URLError, ConnectionError, TimeoutError):
        time.sleep(1)
sys.exit(f"schemathesis: the server was not ready within {wait:.0f} s")
EOF
  cat "$work/server.log" >&2
  exit 1
fi
echo "schemathesis: server ready in $((SECONDS - t0)) s at $base ($bin)"

# The server's request counters (relight_http_requests_total), saved to a file.
counters() {
  python3 - "$base" "$1" <<'EOF'
import json, re, sys, urllib.request
text = urllib.request.urlopen(sys.argv[1] + "/metrics", timeout=10).read().decode()
counts = {}
for line in text.splitlines():
    m = re.match(r'relight_http_requests_total\{method="([^"]*)",route="([^"]*)",status="([^"]*)"\} (\S+)', line)
    if m:
        counts[" ".join(m.group(1, 2, 3))] = int(float(m.group(4)))
json.dump(counts, open(sys.argv[2], "w"))
EOF
}
counters "$work/before.json"

# Checks: all of them but three that cannot apply to this API, which has one user (the
# admin token) and no links between operations:
# - object_level_authorization: tests access between users;
# - use_after_free, ensure_resource_availability: follow create/delete links between
#   operations to resources.
# positive_data_acceptance is tuned in schemathesis.toml (422 stays acceptable).
# Times: a response slower than 45 s fails max_response_time (the slowest legal requests,
# such as illuminance at 10,000 points inside a room, take 15-30 s on 2 cores); the
# server's own limit answers 503 at 60 s (not_a_server_error); schemathesis gives up on a
# request at 90 s.
t1=$SECONDS
set +e
SCHEMATHESIS_HOOKS=$here/hooks.py schemathesis --config-file "$here/schemathesis.toml" \
  run "$base/api/openapi.json" \
  --checks all \
  --exclude-checks object_level_authorization,use_after_free,ensure_resource_availability \
  --header "Authorization: Bearer $token" \
  --max-examples "$examples" --seed "$seed" --workers 1 \
  --max-response-time 45 --request-timeout 90 \
  --generation-database none --no-color --output-truncate true 2>&1 | tee "$work/st.log"
status=${PIPESTATUS[0]}
set -e
wall=$((SECONDS - t1))
if ! kill -0 "$pid" 2>/dev/null; then
  echo "schemathesis: the server died during the run" >&2
  cat "$work/server.log" >&2
  exit 1
fi
# The scene writes with real content: upload a small lit box as a zipped scene folder,
# wait for its bake, export it, delete it. (Small: the bundled scenes already hold most of
# the 2 GB budget.)
python3 - "$base" "$token" <<'EOF' || status=1
import io, sys, time, urllib.error, urllib.request, zipfile
base, token = sys.argv[1:3]
auth = {"Authorization": "Bearer " + token}
def call(method, path, body=None, headers={}):
    req = urllib.request.Request(base + path, data=body, method=method, headers={**auth, **headers})
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()
# A 2 m box of grey walls facing in, with a glowing square under its ceiling.
v = [(x, y, z) for x in (0, 2) for y in (0, 2) for z in (0, 2)]
faces = [(1, 3, 7, 5), (2, 6, 8, 4), (1, 5, 6, 2), (3, 4, 8, 7), (1, 2, 4, 3), (5, 7, 8, 6)]
obj = "mtllib box.mtl\no walls\nusemtl grey\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in v)
obj += "".join("f " + " ".join(map(str, reversed(f))) + "\n" for f in faces)
obj += "o lamp\nusemtl glow\nv 0.8 1.99 0.8\nv 1.2 1.99 0.8\nv 1.2 1.99 1.2\nv 0.8 1.99 1.2\nf 9 10 11 12\n"
mtl = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl glow\nKd 0 0 0\nKe 1000 1000 1000\n"
buf = io.BytesIO()
with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
    z.writestr("box/box.obj", obj)
    z.writestr("box/box.mtl", mtl)
    z.writestr("box/scene.toml", "[mesh]\ntarget_patches = 300\n")
s, b = call("PUT", "/api/scenes/st-upload", buf.getvalue(), {"Content-Type": "application/zip"})
assert s == 202, (s, b)
deadline = time.monotonic() + 120
while True:
    s, b = call("GET", "/api/scenes/st-upload")
    if s == 200:
        break
    assert s == 503 and time.monotonic() < deadline, (s, b)
    time.sleep(0.5)
s, b = call("GET", "/api/scenes/st-upload/export.glb?light.glow=0.5")
assert s == 200 and b[:4] == b"glTF", (s, b[:400])
s, b = call("DELETE", "/api/scenes/st-upload")
assert s == 204, (s, b)
s, b = call("GET", "/api/scenes/st-upload")
assert s == 404, (s, b)
print("schemathesis: upload, bake, export and delete of a real scene: ok")
EOF
counters "$work/after.json"
ops=$(sed -n 's/^ *Tested: \([0-9]*\).*/\1/p' "$work/st.log" | head -n 1)
cases=$(sed -n 's/^ *\([0-9]*\) generated.*/\1/p' "$work/st.log" | head -n 1)
# What the server answered during the run, per documented operation and status class.
python3 - "$base" "$work/before.json" "$work/after.json" <<'EOF'
import collections, json, sys, urllib.request
spec = json.load(urllib.request.urlopen(sys.argv[1] + "/api/openapi.json", timeout=10))
before, after = (json.load(open(f)) for f in sys.argv[2:4])
table = collections.defaultdict(collections.Counter)
for key, n in after.items():
    method, route, status = key.split()
    n -= before.get(key, 0) + (key == "GET /metrics 200")  # the counters' own request
    documented = method.lower() in spec["paths"].get(route, {})
    row = f"{method} {route}" if documented else "other methods and paths"
    if n > 0:
        table[row][status[0] + "xx"] += n
print("schemathesis: requests served, by operation and status class:")
for row, c in sorted(table.items(), key=lambda rc: (rc[0].startswith("other"), rc[0].split()[::-1])):
    print(f"  {row:42} " + "  ".join(f"{k} {c[k]:4}" for k in sorted(c)))
print(f"schemathesis: {sum(sum(c.values()) for c in table.values())} requests served")
EOF
echo "schemathesis: run size: ${ops:-?} operations × up to $examples fuzzed examples each" \
  "(plus the examples, coverage and stateful phases): ${cases:-?} test cases in ${wall} s" \
  "(seed $seed, schemathesis $st_version)"
if grep -q "panicked" "$work/server.log"; then
  echo "schemathesis: the server panicked:" >&2
  grep -n -A3 "panicked" "$work/server.log" >&2
  status=1
fi
exit "$status"
