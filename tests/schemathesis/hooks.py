"""schemathesis hooks for relight (loaded through schemathesis.toml).

1. Deserializers for the binary answers, so that they are checked too: the images must
   start with their format's signature, and the binary patch, radiosity and mesh buffers
   must have exactly the length their headers and layouts promise. A malformed body fails
   the response schema check.
2. `every_operation_answers_2xx`: fails the run when an operation never answered 2xx, so
   that a run cannot pass by only ever reaching 404s and 422s. Scene writes (PUT and
   DELETE) are exempt: random bytes are never a valid scene, and the bundled scenes may
   not be deleted; run.sh uploads, exports and deletes a real scene after the run.
3. A serializer for the upload bodies (zip and glTF binary): generated values are sent
   as their bytes.
"""

import struct

import schemathesis

SIGNATURES = {
    "image/png": b"\x89PNG\r\n\x1a\n",
    "image/jpeg": b"\xff\xd8\xff",
    "image/x-exr": b"\x76\x2f\x31\x01",
}


def _header(response, name):
    value = response.headers.get(name.lower()) or response.headers.get(name)
    if isinstance(value, list):
        value = value[0] if value else None
    return value


@schemathesis.deserializer("image/png", "image/jpeg", "image/x-exr")
def image(ctx, response):
    media = (_header(response, "content-type") or "").split(";")[0].strip()
    body = response.content
    signature = SIGNATURES[media]
    if not body.startswith(signature):
        raise ValueError(f"{media} body does not start with {signature!r}: {body[:16]!r}")
    return f"{media}, {len(body)} bytes"


def _mesh_length(body):
    if len(body) < 20 or body[:8] != b"RLMESH01":
        raise ValueError(f"mesh does not start with RLMESH01 and three counts: {body[:20]!r}")
    nv, nt, nw = struct.unpack_from("<III", body, 8)
    return 20 + 12 * nv + 12 * nt + 4 * nt + 4 * (nv + 1) + 8 * nw


@schemathesis.deserializer("model/gltf-binary")
def glb(ctx, response):
    body = response.content
    if len(body) < 20 or body[:4] != b"glTF":
        raise ValueError(f"glTF binary does not start with 'glTF': {body[:16]!r}")
    version, length = struct.unpack_from("<II", body, 4)
    if version != 2 or length != len(body):
        raise ValueError(f"GLB header: version {version}, length {length}, body {len(body)} bytes")
    return f"glTF binary, {len(body)} bytes"


@schemathesis.serializer("application/zip", "model/gltf-binary")
def upload(ctx, value):
    """Upload bodies: bytes as they are, anything else as its text."""
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    return str(value).encode()


@schemathesis.deserializer("application/octet-stream")
def octet_stream(ctx, response):
    body = response.content
    path = ctx.operation.path
    if path.endswith("/mesh") or path.endswith("/mesh/preview"):
        want = _mesh_length(body)
    else:
        n = _header(response, "x-relight-patches")
        if n is None:
            raise ValueError("binary answer without X-Relight-Patches")
        per_patch = 32 if path.endswith("/patches") else 12
        want = per_patch * int(n)
    if len(body) != want:
        raise ValueError(f"binary answer of {len(body)} bytes, its layout gives {want}")
    return f"{len(body)} bytes"


@schemathesis.check
class every_operation_answers_2xx:
    """Fail if a tested operation never returned a 2xx response during the run."""

    def __init__(self):
        self.reached = set()
        self.tested = set()

    def after_response(self, ctx, response, case):
        label = case.operation.label
        if case.operation.method.upper() in ("PUT", "DELETE"):
            return
        self.tested.add(label)
        if 200 <= response.status_code < 300:
            self.reached.add(label)

    def after_run(self, ctx):
        unreachable = self.tested - self.reached
        if unreachable:
            raise AssertionError("never answered 2xx: " + ", ".join(sorted(unreachable)))
