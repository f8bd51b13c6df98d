//! Details of the contract: names in requests are never empty, and scene writes on a server
//! that does not take them answer a status the document lists.

use super::*;

/// Request properties whose strings name something in the scene (or a file): a camera,
/// surfaces, grids, light groups (as map keys in `lights`), the weather file.
const NAMES: [&str; 8] = [
    "camera", "surfaces", "grids", "grid", "groups", "group", "lights", "weather",
];

fn resolve<'a>(doc: &'a Value, s: &'a Value) -> &'a Value {
    match s["$ref"].as_str() {
        Some(r) => doc.pointer(r.strip_prefix('#').unwrap()).unwrap(),
        None => s,
    }
}

/// Walks a request schema; `name` is set while the schema is (part of) a property that
/// names things. Pushes every name site to `sites` and every one without `minLength` ≥ 1 to
/// `bad`.
fn names(
    doc: &Value,
    s: &Value,
    at: &str,
    name: bool,
    depth: usize,
    sites: &mut Vec<String>,
    bad: &mut Vec<String>,
) {
    assert!(depth < 32, "{at}: too deep");
    let s = resolve(doc, s);
    let min_one = |v: &Value| v["minLength"].as_u64().is_some_and(|m| m >= 1);
    for k in ["oneOf", "anyOf", "allOf"] {
        for (i, x) in s[k].as_array().into_iter().flatten().enumerate() {
            names(
                doc,
                x,
                &format!("{at}/{k}[{i}]"),
                name,
                depth + 1,
                sites,
                bad,
            );
        }
    }
    if let Some(items) = s.get("items") {
        names(doc, items, &format!("{at}[]"), name, depth + 1, sites, bad);
    }
    let props = s["properties"].as_object();
    for (k, x) in props.into_iter().flatten() {
        let named = NAMES.contains(&k.as_str());
        names(doc, x, &format!("{at}.{k}"), named, depth + 1, sites, bad);
    }
    if let Some(values) = s.get("additionalProperties").filter(|v| v.is_object()) {
        if name {
            // A map keyed by names: its keys are the names.
            sites.push(format!("{at}{{key}}"));
            if !min_one(&s["propertyNames"]) {
                bad.push(format!("{at}{{key}}"));
            }
        }
        names(
            doc,
            values,
            &format!("{at}{{}}"),
            false,
            depth + 1,
            sites,
            bad,
        );
    }
    let string = s["type"] == "string"
        || s["type"]
            .as_array()
            .is_some_and(|t| t.iter().any(|t| t == "string"));
    if name && string && s.get("enum").is_none() {
        sites.push(at.to_string());
        if !min_one(s) {
            bad.push(at.to_string());
        }
    }
}

/// Every name site in the document's request bodies and query and path parameters; the
/// ones that allow an empty string.
fn name_sites(doc: &Value) -> (Vec<String>, Vec<String>) {
    let (mut sites, mut bad) = (Vec::new(), Vec::new());
    for (path, item) in doc["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            let at = format!("{method} {path}");
            for (ct, c) in op["requestBody"]["content"]
                .as_object()
                .into_iter()
                .flatten()
            {
                let at = format!("{at} ({ct})");
                names(doc, &c["schema"], &at, false, 0, &mut sites, &mut bad);
            }
            for p in op["parameters"].as_array().into_iter().flatten() {
                let p = resolve(doc, p);
                let n = p["name"].as_str().unwrap();
                let named = n == "id" || NAMES.contains(&n);
                let at = format!("{at} ?{n}");
                names(doc, &p["schema"], &at, named, 0, &mut sites, &mut bad);
            }
        }
    }
    (sites, bad)
}

#[test]
fn names_in_requests_are_never_empty() {
    let doc = spec();
    let (sites, bad) = name_sites(&doc);
    assert!(bad.is_empty(), "names that may be empty: {bad:#?}");
    // The walk finds them: the camera (body and query), surfaces, grids, a target's grid,
    // groups, the keys of `lights`, the weather file, the scene id.
    for needle in [
        "post /api/scenes/{id}/render (application/json).camera/oneOf[0]",
        "get /api/scenes/{id}/render.png ?camera",
        "post /api/scenes/{id}/illuminance (application/json).surfaces[]",
        "post /api/scenes/{id}/batch (application/json).grids[]",
        "post /api/scenes/{id}/optimize (application/json).targets[].grid",
        "post /api/scenes/{id}/optimize (application/json).groups[]",
        "post /api/scenes/{id}/radiosity (application/json).lights{key}",
        "post /api/scenes/{id}/batch (application/json).states[].lights{key}",
        "post /api/scenes/{id}/annual (application/json).weather",
        "put /api/scenes/{id} ?id",
    ] {
        assert!(
            sites.iter().any(|s| s == needle),
            "{needle} not found in {sites:#?}"
        );
    }
    // And it would notice a name that lost its minLength, or a map without propertyNames.
    for pointer in [
        "/components/schemas/Target/properties/grid/minLength",
        "/components/schemas/Lights/propertyNames",
    ] {
        let mut broken = doc.clone();
        let (parent, key) = pointer.rsplit_once('/').unwrap();
        broken
            .pointer_mut(parent)
            .and_then(Value::as_object_mut)
            .and_then(|o| o.remove(key))
            .unwrap_or_else(|| panic!("{pointer} is not in the document"));
        assert!(
            !name_sites(&broken).1.is_empty(),
            "{pointer} removed unnoticed"
        );
    }
}

/// A server over an empty scenes folder.
fn server(admin_token: Option<&str>, read_only: bool) -> (tempfile::TempDir, Router) {
    let root = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(root.path().join("scenes")).unwrap();
    let config = ServerConfig {
        scenes: root.path().join("scenes"),
        cache: root.path().join("cache"),
        admin_token: admin_token.map(String::from),
        read_only,
        ..ServerConfig::default()
    };
    let state = AppState::new(config).unwrap();
    (root, router(state))
}

#[tokio::test]
async fn scene_writes_on_a_server_without_them_answer_a_documented_status() {
    let doc = spec();
    let token = "contract-test-token-0123456789";
    for (admin, read_only, why) in [(None, false, "disabled"), (Some(token), true, "read-only")] {
        let (_root, app) = server(admin, read_only);
        for method in ["put", "delete"] {
            let mut req = Request::builder()
                .method(method.to_uppercase().as_str())
                .uri("/api/scenes/new-scene")
                .header(header::AUTHORIZATION, format!("Bearer {token}"));
            if method == "put" {
                req = req.header(header::CONTENT_TYPE, "model/gltf-binary");
            }
            let resp = app
                .clone()
                .oneshot(req.body(Body::from("glTF")).unwrap())
                .await
                .unwrap();
            let status = resp.status();
            let op = &doc["paths"]["/api/scenes/{id}"][method];
            let listed = &op["responses"][status.as_str()];
            assert!(
                listed.is_object(),
                "{method} ({why}) answers {status}, which the document does not list"
            );
            // The one status for this case, and the document says when it is given.
            assert_eq!(status, StatusCode::FORBIDDEN, "{method} ({why})");
            let described = resolve(&doc, listed)["description"].as_str().unwrap_or("");
            assert!(
                described.contains("admin token") && described.contains("read-only"),
                "{described}"
            );
        }
    }
}
