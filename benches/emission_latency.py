#!/usr/bin/env python3
"""Per-patch emission answers over HTTP, one keep-alive connection: the latency of
`POST /api/scenes/{id}/radiosity` with an arbitrary emission vector (issue #47).

Start a release server first (`cargo run --release -- serve --addr 127.0.0.1:8093`), then:
    python3 benches/emission_latency.py cornell-box [PORT [REQUESTS]]
Three kinds of emission, each REQUESTS times (default 25) after 3 warm-ups, a different
patch or pattern every time:
- one patch: a single emitting patch (sparse form `{"emission": {"<patch>": [r, g, b]}}`);
- 1 % of patches: every 100th patch, offset per request (sparse form);
- dense: every patch emitting (array form).
Prints the HTTP round-trip p50 and p90 of each, binary answers (n × 3 f32), and checks the
answer's size.
"""
import http.client
import json
import sys
import time

scene = sys.argv[1]
port = int(sys.argv[2]) if len(sys.argv) > 2 else 8093
count = int(sys.argv[3]) if len(sys.argv) > 3 else 25
c = http.client.HTTPConnection("127.0.0.1", port)
c.request("GET", f"/api/scenes/{scene}")
info = json.loads(c.getresponse().read())
n = info["patches"]
print(f"{scene}: {n} patches, transfer {info['transfer']}")

KINDS = [
    ("one patch", lambda k: {"emission": {str((k * 7919) % n): [10.0, 10.0, 10.0]}}),
    ("1 % of patches", lambda k: {"emission": {str(i): [5.0, 4.0, 3.0] for i in range(k % 100, n, 100)}}),
    ("dense", lambda k: {"emission": [[1.0 + (i + k) % 3, 1.0, 0.5] for i in range(n)]}),
]
for label, make in KINDS:
    lat = []
    for k in range(count + 3):
        body = json.dumps(make(k))
        t = time.perf_counter()
        c.request("POST", f"/api/scenes/{scene}/radiosity", body,
                  {"content-type": "application/json", "accept": "application/octet-stream"})
        r = c.getresponse()
        data = r.read()
        assert r.status == 200, data[:300]
        assert len(data) == 12 * n, len(data)
        if k >= 3:
            lat.append((time.perf_counter() - t) * 1e3)
    lat.sort()
    print(f"  {label:15s} p50 {lat[len(lat) // 2]:8.1f} ms   p90 {lat[int(len(lat) * 0.9)]:8.1f} ms")
