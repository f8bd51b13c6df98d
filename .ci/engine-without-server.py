#!/usr/bin/env python3
"""The engine (everything outside src/server, src/cli, src/main.rs and src/schema.rs) must
build without the `server` feature. A full no-server build re-checks half the dependency
graph (their features unify differently): minutes of CI. These are the ways the engine's
code can depend on the server stack, checked statically instead:

- a path into axum, tokio, tower, hyper, utoipa or the server modules;
- an OpenAPI attribute (`#[schema(...)]`, `derive(ToSchema)`, `#[param(...)]`) that is not
  inside `#[cfg_attr(feature = "server", ...)]` (without the feature it is an unknown
  attribute).
"""
import pathlib
import re
import sys

SERVER_ONLY = ("server", "cli")
OWN = {"main.rs", "schema.rs", "lib.rs"}
PATH = re.compile(r"\b(axum|tokio|tower|tower_http|hyper|hyper_util|utoipa|serde_path_to_error)::"
                  r"|\bcrate::(server|schema|cli)\b")
ATTR = re.compile(r"#\[(?P<body>(?:[^\[\]]|\[[^\]]*\])*)\]", re.S)
OPENAPI = re.compile(r"\bschema\s*\(|\bToSchema\b|\bIntoParams\b|\bparam\s*\(")

src = pathlib.Path(__file__).resolve().parent.parent / "src"
bad = []
for f in sorted(src.rglob("*.rs")):
    rel = f.relative_to(src)
    if rel.parts[0] in SERVER_ONLY or str(rel) in OWN:
        continue
    text = f.read_text()
    code = re.sub(r"//[^\n]*", "", text)  # comments may name anything
    # What `cfg_attr(feature = "server", ...)` holds is compiled only with the feature.
    kept = []
    for m in ATTR.finditer(code):
        if re.match(r'\s*cfg_attr\(\s*feature\s*=\s*"server"', m.group("body")):
            kept.append(m.span())
    for a, b in reversed(kept):
        code = code[:a] + "\n" * code[a:b].count("\n") + code[b:]
    line = lambda pos: code[:pos].count("\n") + 1
    for m in PATH.finditer(code):
        bad.append(f"{rel}:{line(m.start())}: uses {m.group(0)} outside cfg_attr(feature = \"server\")")
    for m in ATTR.finditer(code):
        if OPENAPI.search(m.group("body")):
            bad.append(f"{rel}:{line(m.start())}: an OpenAPI attribute outside "
                       "cfg_attr(feature = \"server\")")
for b in bad:
    print(b, file=sys.stderr)
sys.exit(1 if bad else 0)
