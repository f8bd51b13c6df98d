#!/usr/bin/env python3
"""Luminaires placed per request over HTTP (issue #47): the latency of one lighting state
with `luminaires`, one request at a time.

Start a release server first (`cargo run --release -- serve --addr 127.0.0.1:8093`), then:
    python3 benches/placed_latency.py PORT SCENE BODY.json [ENDPOINT [REQUESTS]]
BODY.json is the request body (a lighting state with `luminaires`, and what to answer);
ENDPOINT is `illuminance` (default) or `radiosity`; REQUESTS defaults to 7. Prints the p50
and the fastest round trip, and the answer's size.

The bodies of docs/performance.md ("Luminaires placed per request"):
- desk-room: {"lights": {"ceiling": 0, "lamp": 0}, "luminaires": [{"id": "task",
  "position": [1.2, 2.6, 2.4], "ies": <scenes/office-floor/downlight.ies>, "lumens": 1200}],
  "surfaces": ["desk_top"]};
- office-floor: luminaires s1_1 … s1_6 moved 0.5 m along +x, and four `downlight.ies`
  added at [2 + 3k, 2.95, 7.5] (k = 0 … 3); with "grids": ["s2", "n3", "n4"] or without.
"""
import json
import statistics
import sys
import time
import urllib.request

port, scene, body = sys.argv[1], sys.argv[2], json.load(open(sys.argv[3]))
endpoint = sys.argv[4] if len(sys.argv) > 4 else "illuminance"
count = int(sys.argv[5]) if len(sys.argv) > 5 else 7
url = f"http://127.0.0.1:{port}/api/scenes/{scene}/{endpoint}"
times = []
for _ in range(count):
    req = urllib.request.Request(
        url, data=json.dumps(body).encode(), headers={"content-type": "application/json"}
    )
    t = time.perf_counter()
    with urllib.request.urlopen(req) as r:
        out = r.read()
    times.append((time.perf_counter() - t) * 1e3)
print(
    f"{scene} {endpoint}: p50 {statistics.median(times):.1f} ms "
    f"(fastest {min(times):.1f}, {count} requests), {len(out)} bytes"
)
