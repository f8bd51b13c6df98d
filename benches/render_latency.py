#!/usr/bin/env python3
"""Sequential render latency over HTTP, one keep-alive connection (like one slider user).

Start a release server first (`cargo run --release -- serve --addr 127.0.0.1:8093`), then:
    python3 benches/render_latency.py cornell-box 1024 768 jpeg [PORT [QUALITY]]
Every request changes the first light group's intensity. Prints the HTTP round-trip p50/p90
and the server-side time (x-relight-render-ms) p50 over 180 requests after 20 warm-ups (the
first of them builds a `final` view).
"""
import http.client
import json
import sys
import time

scene, w, h, fmt = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
port = int(sys.argv[5]) if len(sys.argv) > 5 else 8093
quality = sys.argv[6] if len(sys.argv) > 6 else "fast"
c = http.client.HTTPConnection("127.0.0.1", port)
c.request("GET", f"/api/scenes/{scene}")
group = json.loads(c.getresponse().read())["lights"][0]["id"]
lat, srv = [], []
for i in range(200):
    body = json.dumps({"lights": {group: 0.2 + (i % 17) * 0.1}, "width": w, "height": h, "format": fmt,
                       "quality": quality})
    t = time.perf_counter()
    c.request("POST", f"/api/scenes/{scene}/render", body, {"content-type": "application/json"})
    r = c.getresponse()
    data = r.read()
    assert r.status == 200, data[:300]
    lat.append((time.perf_counter() - t) * 1e3)
    srv.append(float(r.getheader("x-relight-render-ms", "nan")))
lat, srv = sorted(lat[20:]), sorted(srv[20:])
q = lambda a, p: a[int(p * (len(a) - 1))]
print(f"{scene} {w}x{h} {fmt} {quality}: HTTP p50 {q(lat, .5):.2f} ms, p90 {q(lat, .9):.2f} ms; "
      f"server p50 {q(srv, .5):.2f} ms; {len(data)} bytes")
