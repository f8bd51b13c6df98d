#!/usr/bin/env python3
"""Writes gallery.gltf, gallery.bin and wood.png: a 6 m x 4 m gallery, 3.2 m high, as
glTF 2.0. It shows what relight reads from glTF: a node tree with transforms, one plinth
mesh instanced three times, a textured floor (baseColorTexture), an emissive ceiling
panel (KHR_materials_emissive_strength), three spotlights sharing one light definition
(one light group) and a point light (KHR_lights_punctual). Metres, y up. Run from this
folder; the generated files are committed."""
import base64, json, math, struct, zlib

W, H, D = 6.0, 3.2, 4.0
bin_ = bytearray()
views, accessors, meshes = [], [], []


def align():
    while len(bin_) % 4:
        bin_.append(0)


def add_mesh(name, tris_pos, material, uv=None):
    """A mesh from triangles given as corner triples (counter-clockwise from the front);
    `uv` maps a position to texture coordinates (TEXCOORD_0) for textured materials."""
    verts, idx, seen = [], [], {}
    for tri in tris_pos:
        for p in tri:
            key = tuple(round(c, 6) for c in p)
            if key not in seen:
                seen[key] = len(verts)
                verts.append(key)
            idx.append(seen[key])
    align()
    off = len(bin_)
    for v in verts:
        bin_.extend(struct.pack("<3f", *v))
    views.append({"buffer": 0, "byteOffset": off, "byteLength": 12 * len(verts), "target": 34962})
    lo = [min(v[k] for v in verts) for k in range(3)]
    hi = [max(v[k] for v in verts) for k in range(3)]
    accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(verts),
                      "type": "VEC3", "min": lo, "max": hi})
    pos = len(accessors) - 1
    attributes = {"POSITION": pos}
    if uv is not None:
        align()
        off = len(bin_)
        for v in verts:
            bin_.extend(struct.pack("<2f", *uv(v)))
        views.append({"buffer": 0, "byteOffset": off, "byteLength": 8 * len(verts), "target": 34962})
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(verts),
                          "type": "VEC2"})
        attributes["TEXCOORD_0"] = len(accessors) - 1
    align()
    off = len(bin_)
    for i in idx:
        bin_.extend(struct.pack("<H", i))
    views.append({"buffer": 0, "byteOffset": off, "byteLength": 2 * len(idx), "target": 34963})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": len(idx),
                      "type": "SCALAR"})
    meshes.append({"name": name, "primitives": [
        {"attributes": attributes, "indices": len(accessors) - 1, "material": material}]})
    return len(meshes) - 1


def quad(a, b, c, d):
    return [(a, b, c), (a, c, d)]


def box(lo, hi, inward):
    """The faces of an axis-aligned box, fronts facing out (or in)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    faces = [
        quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)),  # bottom, facing -y
        quad((x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)),  # top, +y
        quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)),  # -x
        quad((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)),  # +x
        quad((x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)),  # -z
        quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)),  # +z
    ]
    tris = [t for f in faces for t in f]
    return [(t[0], t[2], t[1]) for t in tris] if inward else tris


# Materials: linear base colours; metallicFactor 0 (glTF's default is 1, a metal).
def pbr(name, rgb, tex=None):
    m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(rgb) + [1.0],
                                                "metallicFactor": 0.0, "roughnessFactor": 0.9}}
    if tex is not None:
        m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex}
    return m


materials = [
    pbr("plaster", (0.78, 0.77, 0.74)),
    pbr("ceiling", (0.85, 0.85, 0.85)),
    pbr("oak", (1.0, 1.0, 1.0), tex=0),
    pbr("plinth", (0.62, 0.62, 0.66)),
    {"name": "panel", "emissiveFactor": [1.0, 0.95, 0.88],
     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 600.0}},
     "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}},
]

# The room: separate meshes so that each surface has its own name.
floor = add_mesh("floor", quad((0, 0, 0), (0, 0, D), (W, 0, D), (W, 0, 0)), 2,
                 uv=lambda p: (p[0], p[2]))
ceiling = add_mesh("ceiling", quad((0, H, 0), (W, H, 0), (W, H, D), (0, H, D)), 1)
walls = add_mesh("walls", [t for i, t in enumerate(box((0, 0, 0), (W, H, D), True))
                           if i // 2 not in (0, 1)], 0)
# One plinth mesh, 0.5 m square and 0.9 m high, centred on its node's origin.
plinth = add_mesh("plinth", box((-0.25, 0, -0.25), (0.25, 0.9, 0.25), False), 3)
# The ceiling panel: 1.2 m x 0.6 m, facing down, just below the ceiling.
panel = add_mesh("panel", quad((-0.6, 0, -0.3), (0.6, 0, -0.3), (0.6, 0, 0.3), (-0.6, 0, 0.3)), 4)

lights = [
    {"name": "Spots", "type": "spot", "intensity": 2000.0, "color": [1.0, 0.92, 0.8],
     "spot": {"innerConeAngle": math.radians(12), "outerConeAngle": math.radians(25)}},
    {"name": "Lamp", "type": "point", "intensity": 150.0, "color": [1.0, 0.85, 0.65]},
]

# A quarter turn about x: a spot's -z axis then points down.
down = [-math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)]
nodes = [
    {"name": "room", "children": [1, 2, 3, 4, 5, 9, 13]},
    {"name": "floor", "mesh": floor},
    {"name": "ceiling", "mesh": ceiling},
    {"name": "walls", "mesh": walls},
    {"name": "panel", "mesh": panel, "translation": [3.0, H - 0.01, 3.0]},
    # Three plinths, one mesh; the group node shifts them all.
    {"name": "plinths", "translation": [0.0, 0.0, 1.4], "children": [6, 7, 8]},
    {"name": "plinth_west", "mesh": plinth, "translation": [1.5, 0, 0]},
    {"name": "plinth_middle", "mesh": plinth, "translation": [3.0, 0, 0], "scale": [1, 1.2, 1]},
    {"name": "plinth_east", "mesh": plinth, "translation": [4.5, 0, 0]},
    # Three spots over the plinths, one light definition: one light group.
    {"name": "spots", "translation": [0.0, H - 0.05, 1.4], "children": [10, 11, 12]},
    {"name": "spot_west", "translation": [1.5, 0, 0], "rotation": down,
     "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "spot_middle", "translation": [3.0, 0, 0], "rotation": down,
     "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "spot_east", "translation": [4.5, 0, 0], "rotation": down,
     "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "lamp", "translation": [5.4, 1.8, 3.5],
     "extensions": {"KHR_lights_punctual": {"light": 1}}},
]


def png(w, h, pixel):
    """An 8-bit RGB PNG."""
    raw = b"".join(b"\x00" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# Oak planks: warm stripes (sRGB codes; relight averages the texture in linear light).
wood = png(16, 16, lambda x, y: (172, 140, 108) if (x // 4 + y // 8) % 2 else (150, 118, 88))
open("wood.png", "wb").write(wood)
open("gallery.bin", "wb").write(bytes(bin_))
doc = {
    "asset": {"version": "2.0", "generator": "relight scenes/gallery/make_scene.py"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
    "extensions": {"KHR_lights_punctual": {"lights": lights}},
    "scene": 0,
    "scenes": [{"name": "Gallery", "nodes": [0]}],
    "nodes": nodes,
    "meshes": meshes,
    "materials": materials,
    "textures": [{"source": 0}],
    "images": [{"uri": "wood.png"}],
    "buffers": [{"uri": "gallery.bin", "byteLength": len(bin_)}],
    "bufferViews": views,
    "accessors": accessors,
}
open("gallery.gltf", "w").write(json.dumps(doc, indent=1) + "\n")
